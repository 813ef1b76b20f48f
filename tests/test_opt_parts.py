"""Building blocks of the optimisers: candidates, constrained refinement, LineBO geometry, options."""

from __future__ import annotations

import numpy as np
import pytest

from ksbo_mav.errors import InputError
from ksbo_mav.opt.acquisition.candidates import local_gaussian, refine, sobol
from ksbo_mav.opt.acquisition.lines import line_grid, safe_interval
from ksbo_mav.opt.options import options_for


def test_sobol_and_local_samples_stay_in_cube_and_respect_fixed_dims() -> None:
    rng = np.random.default_rng(0)
    S = sobol(100, 4, rng)
    assert S.shape == (100, 4) and S.min() >= 0 and S.max() <= 1
    centers = np.array([[0.0, 0.5, 1.0, 0.3], [0.9, 0.1, 0.2, 0.3]])
    free = np.array([True, True, True, False])
    L = local_gaussian(centers, 500, (0.05, 0.3), rng, free=free)
    assert L.shape == (500, 4) and L.min() >= 0 and L.max() <= 1
    np.testing.assert_array_equal(L[:, 3], 0.3)
    # Samples are local: every one is within a few scales of some centre.
    dist = np.min(np.linalg.norm(L[:, None, :] - centers[None], axis=2), axis=1)
    assert np.max(dist) < 6 * 0.3 * np.sqrt(3)


def test_refine_improves_and_never_accepts_infeasible_moves() -> None:
    target = np.array([0.8, 0.8])

    def evaluate(Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        score = -np.sum((Z - target) ** 2, axis=1)
        feasible = Z[:, 0] <= 0.6  # the unconstrained optimum is infeasible
        return score, feasible

    starts = np.array([[0.1, 0.1], [0.5, 0.2]])
    X, s = refine(evaluate, starts, np.random.default_rng(1), rounds=6, samples=64, scale=0.2)
    assert np.all(X[:, 0] <= 0.6)
    assert np.all(s > evaluate(starts)[0])
    # It gets close to the constrained optimum (0.6, 0.8).
    assert np.min(np.linalg.norm(X - [0.6, 0.8], axis=1)) < 0.1


def test_line_grid_stays_in_cube_and_contains_the_point() -> None:
    x = np.array([0.2, 0.9, 0.5])
    d = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    s, P = line_grid(x, d, 50)
    assert P.min() >= 0 and P.max() <= 1
    assert np.any(np.all(np.isclose(P, x), axis=1))
    # The segment reaches the cube's faces at both ends.
    assert np.isclose(P[0, 0], 0.0) or np.isclose(P[0, 1], 0.0)
    assert np.isclose(P[-1, 1], 1.0)


@pytest.mark.parametrize(
    "mask, i0, expect",
    [
        ([0, 1, 1, 1, 0, 1], 2, (1, 3)),
        ([1, 1, 1], 0, (0, 2)),
        ([0, 0, 1], 1, (1, 1)),
        ([1, 0, 1], 2, (2, 2)),
    ],
)
def test_safe_interval(mask: list[int], i0: int, expect: tuple[int, int]) -> None:
    assert safe_interval(np.array(mask, dtype=bool), i0) == expect


def test_options_defaults_and_unknown_names() -> None:
    assert options_for("safeopt").rule == "safeopt"
    assert options_for("ksbo", {"beta": 3.0}).beta == 3.0
    with pytest.raises(InputError, match="unknown option"):
        options_for("ksbo", {"betta": 3.0})
    with pytest.raises(InputError, match="rule"):
        options_for("ksbo", {"rule": "greedy"})
    with pytest.raises(InputError, match=r"lengthscale must be a number in \(0, inf\)"):
        options_for("ksbo", {"lengthscale": 0.0})


def test_order_selection_respects_max_order() -> None:
    from ksbo_mav.opt.models.selection import KernelSelection, select_kernel

    rng = np.random.default_rng(0)
    X = rng.random((20, 6))
    y = np.sin(6 * X[:, 0] * X[:, 1]) + X[:, 2]
    opts = options_for("ksbo", {"max_order": 2, "trials": 10})
    sel = select_kernel(X, y, opts, opts.lengthscale, seed=0)
    assert isinstance(sel, KernelSelection) and sel.method == "cree"
    assert sel.selected and set(sel.orders) <= {1, 2} and len(sel.orders) == 2
    assert set(sel.cree) == {1, 2}
    with pytest.raises(InputError, match="max_order"):
        options_for("ksbo", {"max_order": 0})
