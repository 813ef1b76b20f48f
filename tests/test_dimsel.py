"""Dimension selection (random forest / permutation importance), keep rule, and LHS prior designs."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import qmc

from ksbo_mav.errors import InputError
from ksbo_mav.select import (
    kernel_from_selection, keep_dimensions, lhs_design, select_dimensions, select_dimensions_for_orders,
)

D = 9
RELEVANT = {0, 1, 2, 3}


def _data(n=48, seed=0):
    X = qmc.LatinHypercube(d=D, seed=seed).random(n)
    y = 2 * X[:, 0] * X[:, 1] + 2 * X[:, 2] * X[:, 3] + 0.01 * np.random.default_rng(seed).standard_normal(n)
    return X, y


@pytest.mark.parametrize("method", ["forest", "permutation"])
def test_recovers_relevant_dimensions_and_drops_noise(method):
    X, y = _data()
    sel = select_dimensions(X, y, order=2, method=method, seed=0)
    assert RELEVANT <= set(sel.dims)
    imp = sel.importances
    assert imp.sum() == pytest.approx(1) and np.all(imp >= 0)
    assert min(imp[list(RELEVANT)]) > max(imp[4:])  # every relevant dimension outranks every noise dimension
    if method == "permutation":
        assert set(sel.dims) == RELEVANT
    else:
        assert len(set(sel.dims) - RELEVANT) <= 1


def test_orders_share_importances_and_respect_minimum():
    X, y = _data()
    out = select_dimensions_for_orders(X, y, [2, 6], seed=1)
    assert set(out) == {2, 6}
    np.testing.assert_allclose(out[2].importances, out[6].importances)
    assert len(out[6].dims) >= 6 and RELEVANT <= set(out[6].dims)
    by_depth = select_dimensions_for_orders(X, y, [1, 2], seed=1, max_depth="order")
    assert by_depth[1].order == 1 and len(by_depth[2].dims) >= 2


def test_keep_rule():
    share = np.array([0.4, 0.3, 0.2, 0.05, 0.05, 0, 0, 0, 0])
    assert keep_dimensions(share, 1, threshold=1.0) == (0, 1, 2)  # >= 1/9
    assert keep_dimensions(share, 1, threshold=0.5) == (0, 1, 2)  # >= 1/18 = 0.056
    assert keep_dimensions(share, 4, threshold=1.0) == (0, 1, 2, 3)  # at least the order
    assert keep_dimensions(share, 1, threshold=1.0, top_m=2) == (0, 1)
    assert keep_dimensions(np.zeros(D), 2) == tuple(range(D))  # nothing predictive: keep all
    with pytest.raises(InputError, match="top_m"):
        keep_dimensions(share, 3, top_m=2)


def test_kernel_from_selection():
    X, y = _data()
    sel = select_dimensions_for_orders(X, y, [2, 3], method="forest", seed=0)
    k = kernel_from_selection(D, sel, lengthscales=0.3)
    assert k.terms_[0].dims == tuple(sorted(sel[2].dims)) and k.terms_[1].dims == tuple(sorted(sel[3].dims))
    assert k(X[:5]).shape == (5, 5)


def test_dimension_selection_bad_input():
    X, y = _data()
    with pytest.raises(InputError, match="method"):
        select_dimensions(X, y, 2, method="mdi")  # type: ignore[arg-type]
    with pytest.raises(InputError, match="finite"):
        select_dimensions(X, np.full_like(y, np.nan), 2)
    with pytest.raises(InputError, match="order"):
        select_dimensions(X, y, 10)


def test_lhs_box_is_latin_and_in_cube():
    U = lhs_design(36, D, seed=3)
    assert U.shape == (36, D) and np.all((U >= 0) & (U <= 1))
    strata = np.floor(U * 36).astype(int)
    assert all(sorted(strata[:, j]) == list(range(36)) for j in range(D))
    np.testing.assert_array_equal(U, lhs_design(36, D, seed=3))


def test_lhs_local_stays_in_clipped_trust_region():
    c = np.array([0.15, 0, 0.1, 0.167, 0, 0.067, 0.2, 0, 0.25])
    U = lhs_design(36, D, design="local", center=c, radius=0.1, seed=0)
    lo, hi = np.clip(c - 0.1, 0, 1), np.clip(c + 0.1, 0, 1)
    assert np.all(U >= lo - 1e-12) and np.all(U <= hi + 1e-12)
    strata = np.floor((U - lo) / (hi - lo) * 36).astype(int)  # Latin within the clipped box
    assert all(sorted(np.minimum(strata[:, j], 35)) == list(range(36)) for j in range(D))


@pytest.mark.parametrize(
    "kwargs, msg",
    [
        (dict(n=0, dim=D), "n must"),
        (dict(n=5, dim=D, design="sobol"), "design"),
        (dict(n=5, dim=D, design="local"), "center"),
        (dict(n=5, dim=D, design="local", center=np.full(D, 1.5)), "center"),
        (dict(n=5, dim=D, design="local", center=np.full(D, 0.5), radius=-1), "radius"),
    ],
)
def test_lhs_bad_arguments(kwargs, msg):
    with pytest.raises(InputError, match=msg):
        lhs_design(**kwargs)
