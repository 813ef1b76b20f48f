"""Building blocks of the optimisers: candidates, constrained refinement, LineBO geometry, options."""

from __future__ import annotations

import numpy as np
import pytest

from ksbo_mav.errors import InputError
from ksbo_mav.opt.candidates import local_gaussian, refine, sobol
from ksbo_mav.opt.lines import line_grid, safe_interval
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
    with pytest.raises(InputError, match="positive"):
        options_for("ksbo", {"lengthscale": 0.0})


def test_order_selection_respects_max_order() -> None:
    from ksbo_mav.opt.selection import KernelSelection, select_kernel

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


def test_safe_ucb_margin_keeps_only_points_that_clear_the_threshold_by_the_margin() -> None:
    """``ucb_margin``: the UCB phase's feasible set shrinks to LCB ≥ p_min + margin (the plain set without one)."""
    from ksbo_mav.opt.acquisition import SafeUCB

    class Stub:  # LCB rises along the first coordinate, 0 at 0.5; the UCB along the second
        def bounds(self, Z: np.ndarray):
            lo = Z[:, 0] - 0.5
            return lo + 0.1, np.full(len(Z), 0.05), lo, Z[:, 1]

        def feasible(self, Z: np.ndarray, lcb: np.ndarray) -> np.ndarray:
            return lcb >= 0.0

    Z = np.array([[0.45, 0.9], [0.52, 0.8], [0.58, 0.7], [0.7, 0.1]])
    up, plain = SafeUCB(Stub())(Z)
    np.testing.assert_array_equal(plain, [False, True, True, True])
    np.testing.assert_array_equal(up, Z[:, 1])
    _, wide = SafeUCB(Stub(), margin=0.05)(Z)
    np.testing.assert_array_equal(wide, [False, False, True, True])  # 0.52 clears 0 but not 0.05
    from ksbo_mav.errors import InputError
    from ksbo_mav.opt.options import options_for

    assert options_for("ksbo").ucb_margin == 0.0
    with pytest.raises(InputError, match="ucb_margin"):
        options_for("ksbo", {"ucb_margin": -0.1}).validate()


def test_coordinate_lines_move_one_gain_at_a_time_through_the_incumbent_and_stay_certified() -> None:
    """``line_every``: every k-th BO iteration the query lies on a coordinate line through the incumbent — only one
    gain differs from it, the axes come in turn, and the point is certified (LCB ≥ p_min); other iterations keep
    the usual rule. Off by default; a non-integer is refused."""
    from ksbo_mav.opt import region
    from ksbo_mav.opt.config import SafeBOConfig
    from ksbo_mav.opt.model import ModelSpec, SafetyModel
    from ksbo_mav.opt.safe_bo import SafeBO

    rng = np.random.default_rng(3)
    X = 0.45 + 0.1 * rng.random((15, 3))
    y = 0.4 + 0.2 * X[:, 0] - 0.1 * X[:, 1]
    model = SafetyModel(ModelSpec(orders=(3,), lengthscale=0.1, signal_std=1.0, noise_std=0.01), 3)
    bo = SafeBO(model, SafeBOConfig(line_every=2, n_local=256, n_global=64), np.ones(3, bool),
                np.random.default_rng(0), budget=100)
    bo.fit(X, y)
    axes, kinds = [], []
    for it in range(6):
        xb = region.incumbent(bo)
        p = bo.propose()
        kinds.append(p.kind)
        if p.kind == "line":
            moved = np.flatnonzero(np.abs(p.x - xb) > 1e-12)
            assert moved.size == 1 and p.lcb >= bo.p_min
            axes.append(int(moved[0]))
        bo.observe(p.x, float(0.4 + 0.2 * p.x[0] - 0.1 * p.x[1]))
    assert kinds[0] != "line" and kinds[2] == kinds[4] == "line" and axes == [0, 1]
    assert options_for("ksbo").line_every == 0
    with pytest.raises(InputError, match="line_every"):
        options_for("ksbo", {"line_every": 1.5})


def test_chatter_ratio_tells_a_step_to_step_limit_cycle_from_a_smooth_rate() -> None:
    from ksbo_mav.symptoms import chatter_ratio

    t = np.arange(300) * 0.02
    assert chatter_ratio(np.sin(2 * np.pi * 0.5 * t)) < 0.1  # a slow, smooth rate
    assert chatter_ratio(np.where(np.arange(300) % 2, 1.0, -1.0)) == pytest.approx(2.0)  # flips every step
    noise = np.random.default_rng(0).standard_normal(3000)
    assert chatter_ratio(noise) == pytest.approx(np.sqrt(2), abs=0.05)
    assert np.isnan(chatter_ratio(np.zeros(10))) and np.isnan(chatter_ratio(np.array([1.0, np.nan])))


def test_line_fraction_tells_a_limit_cycle_from_noise_and_from_the_manoeuvre() -> None:
    """``pitch_line`` (issue 13 item AM): a limit cycle is a narrow line holding most of the rate's power; white
    noise spreads its power, so the chatter ratio (√2 for noise) cannot tell them apart but the line can."""
    from ksbo_mav.symptoms import chatter_ratio, line_fraction, rate_symptoms

    rng = np.random.default_rng(0)
    t = np.arange(300) * 0.02
    slow = 0.2 * np.sin(2 * np.pi * 0.5 * t)  # the manoeuvre, below the line's band
    cycle = 0.5 * np.sin(2 * np.pi * 12.5 * t + 0.3)  # a period-4-step cycle at the 50 Hz control rate, dominant
    noise = 0.5 * rng.standard_normal(300)  # as in the simulator: a cycle or noise that matters holds most power
    assert line_fraction(slow + cycle) > 0.8 and line_fraction(slow) < 0.1
    assert line_fraction(noise) < 0.1 and line_fraction(slow + noise) < 0.1
    assert chatter_ratio(noise) > 1.0  # the ratio alone would call the noise a cycle
    assert line_fraction(slow + cycle + 0.5 * noise) > 0.5 and line_fraction(slow + 0.1 * cycle) < 0.5
    assert np.isnan(line_fraction(np.ones(100))) and np.isnan(line_fraction(np.full(20, 0.1)))
    assert set(rate_symptoms(slow + cycle)) == {"pitch_line", "pitch_chatter"}
    assert rate_symptoms(np.full(5, np.nan)) == {}


def test_a_chattering_incumbent_steps_its_d_gain_down_and_only_that_gain() -> None:
    """``chatter_dim``: while the incumbent's flights report ``pitch_line`` (or the chosen ``chatter_symptom``)
    above the threshold, every
    ``chatter_every``-th iteration queries a certified point that lowers only that gain, by at most
    ``chatter_step``; a quiet incumbent gets the usual rule."""
    from ksbo_mav.opt import region
    from ksbo_mav.opt.config import SafeBOConfig
    from ksbo_mav.opt.model import ModelSpec, SafetyModel
    from ksbo_mav.opt.safe_bo import SafeBO

    def state(chatter: float, symptom: str = "pitch_line", threshold: float = 0.5) -> SafeBO:
        rng = np.random.default_rng(3)
        X = 0.45 + 0.1 * rng.random((15, 3))
        y = 0.4 + 0.2 * X[:, 0] - 0.1 * X[:, 1]
        model = SafetyModel(ModelSpec(orders=(3,), lengthscale=0.2, signal_std=1.0, noise_std=0.01), 3)
        cfg = SafeBOConfig(chatter_dim=2, chatter_every=1, chatter_step=0.05, n_local=256, n_global=64,
                           chatter_symptom=symptom, chatter_threshold=threshold)
        bo = SafeBO(model, cfg, np.ones(3, bool), np.random.default_rng(0), budget=100,
                    symptoms=[{symptom: chatter}] * 15)
        bo.fit(X, y)
        bo.iteration = 1
        return bo

    bo = state(0.9)
    xb = region.incumbent(bo)
    p = bo.propose()
    assert p.kind == "symptom" and p.lcb >= bo.p_min
    moved = p.x - xb
    assert np.all(moved[:2] == 0) and -0.05 - 1e-9 <= moved[2] < 0
    assert state(0.05).propose().kind != "symptom"
    assert state(1.4, "pitch_chatter", 1.0).propose().kind == "symptom"
    assert state(0.9, "pitch_chatter", 1.0).propose().kind != "symptom"
    assert options_for("ksbo").chatter_dim == -1
    with pytest.raises(InputError, match="chatter_symptom"):
        options_for("ksbo", {"chatter_symptom": "roll_line"})


def test_the_symptom_rule_keeps_queries_above_a_floor_below_the_lowest_cycling_gain() -> None:
    """``chatter_floor`` (issue 13 item AM): once a flight has cycled, no query sets the gain more than the floor
    below the lowest value a cycling flight had; quiet flights, or a floor of 0, leave the set alone."""
    from ksbo_mav.opt.config import SafeBOConfig
    from ksbo_mav.opt.model import ModelSpec, SafetyModel
    from ksbo_mav.opt.safe_bo import SafeBO
    from ksbo_mav.opt.symptom_rule import symptom_floor

    rng = np.random.default_rng(3)
    X = 0.45 + 0.1 * rng.random((15, 3))

    def bo_with(levels: list[float], floor: float = 0.05) -> SafeBO:
        model = SafetyModel(ModelSpec(orders=(3,), lengthscale=0.2, signal_std=1.0, noise_std=0.01), 3)
        bo = SafeBO(model, SafeBOConfig(chatter_dim=2, chatter_floor=floor, n_local=64, n_global=16),
                    np.ones(3, bool), np.random.default_rng(0), budget=100,
                    symptoms=[{"pitch_line": v} for v in levels])
        bo.fit(X, 0.4 + 0.2 * X[:, 0])
        return bo

    cycling = [0.9 if i % 2 else 0.1 for i in range(15)]  # every other flight cycles
    bo = bo_with(cycling)
    lowest = X[1::2, 2].min()
    assert symptom_floor(bo) == pytest.approx(lowest - 0.05)
    Z = np.tile(X[0], (3, 1))
    Z[:, 2] = [lowest - 0.06, lowest - 0.04, lowest + 0.1]
    assert bo.feasible(Z, np.ones(3)).tolist() == [False, True, True]
    assert symptom_floor(bo_with([0.1] * 15)) is None and bo_with([0.1] * 15).feasible(Z, np.ones(3)).all()
    assert symptom_floor(bo_with(cycling, floor=0.0)) is None
    with pytest.raises(InputError, match="chatter_floor"):
        options_for("ksbo", {"chatter_floor": -0.1})
    with pytest.raises(InputError, match="chatter_dim"):
        options_for("ksbo", {"chatter_dim": -2})


def test_lipschitz_bound_takes_each_flown_point_at_its_worst_flight() -> None:
    """LoSBO's bound (opt.lipschitz): max over flown points of (smallest value there − E − L·distance)."""
    from ksbo_mav.opt.lipschitz import lipschitz_lcb

    X = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.0]])
    y = np.array([0.5, 0.9, -0.4])  # the second point also failed once: it certifies nothing
    Z = np.array([[0.0, 0.1], [0.9, 0.0], [0.5, 0.0]])
    got = lipschitz_lcb(X, y, Z, L=2.0, noise=0.1)
    np.testing.assert_allclose(got, [0.5 - 0.1 - 0.2, max(0.5 - 0.1 - 1.8, -0.4 - 0.1 - 0.2), 0.5 - 0.1 - 1.0])
    assert np.all(lipschitz_lcb(X[:0], y[:0], Z, 2.0, 0.1) == -np.inf)


def test_lipschitz_safety_never_queries_below_p_min_when_the_constant_holds() -> None:
    """With the ``lipschitz`` option the state machine certifies by the data's Lipschitz bound: on a function whose
    true constant is below the configured L, every query is safe and carries exactly that bound as its LCB, and the
    safe set still grows from the edge of safety towards the optimum. Refused: L ≤ 0."""
    from ksbo_mav.opt.config import SafeBOConfig
    from ksbo_mav.opt.lipschitz import lipschitz_lcb
    from ksbo_mav.opt.model import ModelSpec, SafetyModel
    from ksbo_mav.opt.safe_bo import SafeBO

    target = np.array([0.8, 0.7])

    def f(x: np.ndarray) -> float:  # Lipschitz constant 0.8; unsafe in the corner at the origin
        return float(0.8 - 0.8 * np.linalg.norm(x - target))

    model = SafetyModel(ModelSpec(orders=(2,), lengthscale=0.3, signal_std=1.0, noise_std=0.01), 2)
    bo = SafeBO(model, SafeBOConfig(lipschitz=1.0, lipschitz_noise=0.0, n_local=256, n_global=0, expansion_iters=5,
                                    exploit_last=0), np.ones(2, bool), np.random.default_rng(1), budget=40)
    x0 = np.array([0.1, 0.1])
    bo.fit(x0[None, :], np.array([f(x0)]))
    values = []
    for _ in range(40):
        p = bo.propose()
        assert p.kind != "fallback"
        assert p.lcb >= bo.p_min and np.isclose(p.lcb, lipschitz_lcb(bo.X, bo.y, p.x[None, :], 1.0, 0.0)[0])
        values.append(f(p.x))
        bo.observe(p.x, values[-1])
    assert min(values) >= bo.p_min
    assert f(x0) < 0.07 and max(values) > 0.6  # it climbed from the edge of safety (the optimum is 0.8)
    with pytest.raises(InputError, match="lipschitz"):
        options_for("ksbo", {"lipschitz": 0.0})
