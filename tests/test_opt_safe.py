"""Safe BO correctness: synthetic safe optimisation with a well-specified kernel, and the safe-set property."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ksbo_mav
from ksbo_mav.opt.models.safety_model import ModelSpec, SafetyModel
from ksbo_mav.opt.methods.build import build_safe_bo
from ksbo_mav.opt.method_config import SafeBOConfig
from ksbo_mav.opt.methods.safe_bo import SafeBO

D = 3
CENTER = np.array([0.75, 0.3, 0.7])
ELL = 0.2
AMP = 0.6
OFFSET = 0.9


def additive_bumps(x: np.ndarray) -> float:
    """Sum of 1-D Gaussian bumps (a function of the order-1 additive kernel's RKHS, lengthscale ELL).

    Maximum AMP·D − OFFSET = 0.9 at CENTER; the safe set {f ≥ 0} is a rounded region around CENTER, and the
    start X0 below is safe but far from the optimum.
    """
    x = np.asarray(x, dtype=float)
    return float(AMP * np.sum(np.exp(-((x - CENTER) ** 2) / (2 * ELL**2))) - OFFSET)


X0 = np.array([0.5, 0.5, 0.5])
BOUNDS = np.array([[0.0, 1.0]] * D)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ksbo_finds_optimum_without_unsafe_evaluations(seed: int) -> None:
    assert additive_bumps(X0) > 0
    f_opt = additive_bumps(CENTER)
    r = ksbo_mav.optimize(
        additive_bumps, X0, BOUNDS, budget=40, method="ksbo", seed=seed,
        orders=(1,), lengthscale=ELL, signal_std=1.0, noise_std=1e-3, beta=2.0, beta_ucb=2.0, n_local=512,
        n_global=64, safety_kernel="same", recommend_noise=None,
    )
    assert r.n_unsafe == 0
    assert np.min(r.y) >= 0.0
    assert r.fun >= f_opt - 0.02
    assert np.linalg.norm(r.x - CENTER) < 0.1
    # The start was far from the optimum: it really moved.
    assert np.linalg.norm(X0 - CENTER) > 0.3


def test_unconstrained_bo_does_go_unsafe_on_the_same_problem() -> None:
    """Control for the test above: the problem has unsafe regions that an unconstrained optimiser visits."""
    r = ksbo_mav.optimize(additive_bumps, X0, BOUNDS, budget=25, method="random", seed=0)
    assert r.n_unsafe > 0


def _random_state(seed: int, n: int, d: int, ell: float, p_min: float, with_safety: bool = False, **cfg) -> SafeBO:
    rng = np.random.default_rng(seed)
    X = np.clip(0.5 + 0.15 * rng.standard_normal((n, d)), 0, 1)
    y = p_min + rng.normal(0.3, 0.5, n)
    y[0] = p_min + abs(y[0]) + 0.1  # a safe start, as the optimiser assumes
    spec = ModelSpec(orders=tuple(sorted({1, min(2, d)})), lengthscale=ell, signal_std=1.0, noise_std=0.05)
    model = SafetyModel(spec, d, p_min=p_min, seed=seed)
    config = SafeBOConfig(**{"n_local": 128, "n_global": 32, "refine_rounds": 2, "refine_samples": 8,
                             "expansion_iters": seed % 3, **cfg})
    safety = None
    if with_safety:
        safety = SafetyModel(ModelSpec(orders=(d,), lengthscale=ell / 2, signal_std=1.0, noise_std=0.05), d, p_min)
    bo = build_safe_bo(model, config, np.ones(d, dtype=bool), rng, safety_model=safety)
    bo.fit(X, y)
    return bo


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    n=st.integers(1, 25),
    d=st.integers(1, 5),
    ell=st.floats(0.05, 1.0),
    p_min=st.floats(-2.0, 2.0),
    rule=st.sampled_from(["ucb", "safeopt"]),
    with_safety=st.booleans(),
    y_max=st.sampled_from([None, 0.5, 3.0]),
)
def test_safe_set_and_proposals_are_certified(
    seed: int, n: int, d: int, ell: float, p_min: float, rule: str, with_safety: bool, y_max: float | None
) -> None:
    bo = _random_state(seed, n, d, ell, p_min, with_safety, rule=rule, y_max=None if y_max is None else p_min + y_max)
    # The certificate is against every model: recompute both bounds independently of SafeBO.bounds.
    def lcb_all(Z: np.ndarray) -> np.ndarray:
        out = []
        for m in (bo.model, bo.surrogate.safety_model):
            if m is None:
                continue
            mu, sd = m.predict(Z)
            if bo.certificate.y_max is not None:
                mu = np.minimum(mu, bo.certificate.y_max)
            out.append(np.minimum(mu, bo.obs.y.max()) - bo.certificate.beta * sd)
        return np.min(out, axis=0)

    C = bo.region.candidates(bo.obs.X[:1], bo.rng)
    mask = bo.safe_mask(C)
    lcb = lcb_all(C)
    assert np.all(lcb[mask] >= p_min - 1e-12)
    assert np.all(mask <= (lcb >= p_min))  # exclusion balls may only remove points
    p = bo.propose()
    lcb_p = lcb_all(p.x[None, :])
    if p.kind == "fallback":
        # Nothing certified: the proposal is an existing observation (the best-LCB one), never a new point.
        assert any(np.array_equal(p.x, x) for x in bo.obs.X)
    else:
        assert lcb_p[0] >= p_min - 1e-12
    assert np.all((p.x >= 0) & (p.x <= 1))


def test_expansion_phase_is_keyed_to_bo_iterations_not_observations() -> None:
    """SafeCtrlBO's bug: with a large prior its expansion phase never ran. Here it runs for the first iterations."""
    bo = _random_state(0, 40, 3, 0.3, 0.0, refine_rounds=4, refine_samples=32, expansion_iters=2)
    kinds = []
    for _ in range(4):
        p = bo.propose()
        kinds.append(p.kind)
        bo.observe(p.x, 0.5)
    assert kinds[:2] == ["expand", "expand"]
    assert kinds[2:] == ["ucb", "ucb"]


def _interaction(x: np.ndarray) -> float:
    """4-D function: sum of 2-D interactions (x0, x1) and (x2, x3), safe near the centre."""
    x = np.asarray(x, dtype=float)
    return float(1.0 - 3 * (x[0] - 0.5) * (x[1] - 0.4) - 4 * (x[2] - 0.5) ** 2 * (x[3] + 0.5) - (x[1] - 0.4) ** 2)


def test_ksbo_selects_orders_on_the_prior_and_reports_them() -> None:
    rng = np.random.default_rng(0)
    pX = rng.random((30, 4))
    py = np.array([_interaction(x) for x in pX])
    x0 = np.full(4, 0.5)
    r = ksbo_mav.optimize(_interaction, x0, np.array([[0.0, 1.0]] * 4), budget=6, prior=(pX, py), seed=0,
                          top=2, trials=50, n_local=128, n_global=32)
    sel = r.info["selection"]
    assert sel["selected"] is True
    assert r.orders == tuple(sel["orders"]) and len(r.orders) == 2
    assert set(sel["cree"]) == {1, 2, 3, 4}
    # The chosen orders are the two lowest mean C_ree.
    best_two = sorted(sel["cree"], key=sel["cree"].get)[:2]
    assert set(r.orders) == set(best_two)


def test_ksbo_without_prior_uses_default_orders_then_reselects() -> None:
    x0 = np.full(4, 0.5)
    r = ksbo_mav.optimize(_interaction, x0, np.array([[0.0, 1.0]] * 4), budget=16, seed=0, select_at=12,
                          top=2, trials=20, n_local=128, n_global=32, signal_std=1.0)  # min_select: 10
    assert r.info["selection"]["selected"] is False  # one observation: defaults
    assert r.info["reselection"]["selected"] is True
    assert r.info["reselection"]["at_iteration"] == 12
    assert r.orders == tuple(r.info["reselection"]["orders"])
    assert r.nfev == 16


def test_dimension_selection_holds_dropped_dimensions_at_x0() -> None:
    """With dims selection and dropped="fixed", dimensions the forest drops are never moved from x0."""
    rng = np.random.default_rng(1)

    def f(x: np.ndarray) -> float:  # only dimensions 0 and 1 matter
        return float(1.0 - 2 * (x[0] - 0.6) ** 2 - 2 * (x[1] - 0.4) ** 2)

    pX = rng.random((40, 5))
    py = np.array([f(x) for x in pX])
    x0 = np.array([0.5, 0.5, 0.3, 0.7, 0.2])
    r = ksbo_mav.optimize(f, x0, np.array([[0.0, 1.0]] * 5), budget=8, prior=(pX, py), seed=0, orders=None,
                          dims="forest", top=1, trials=20, n_local=128, n_global=32)
    dims = r.dims
    assert dims is not None and len(dims) < 5  # pure-noise dimensions were dropped
    dropped = [i for i in range(5) if i not in dims]
    assert {0, 1} <= set(dims)
    np.testing.assert_allclose(r.X[:, dropped], np.broadcast_to(x0[dropped], (r.nfev, len(dropped))))


def test_no_certified_point_near_an_unsafe_observation() -> None:
    bo = _random_state(3, 20, 3, 0.3, 0.0, n_local=256, n_global=64, refine_rounds=4, refine_samples=32,
                       expansion_iters=10, exclusion_radius=0.1)
    bo.observe(np.array([0.5, 0.5, 0.5]), -1.0)
    C = bo.region.candidates(bo.obs.X[:5], bo.rng)
    C = np.vstack([C, [[0.52, 0.5, 0.5]]])
    mask = bo.safe_mask(C)
    d = np.linalg.norm(C - [0.5, 0.5, 0.5], axis=1)
    assert not mask[-1]
    assert not np.any(mask & (d < 0.1))
    for _ in range(3):
        p = bo.propose()
        if p.kind != "fallback":
            assert np.linalg.norm(p.x - [0.5, 0.5, 0.5]) >= 0.1
        bo.observe(p.x, 0.5)


def _prior_state(explore_from: str, n_prior: int = 2) -> SafeBO:
    """x0 with a nearby prior point and a far, better prior point (a plateau the optimiser should not jump to)."""
    spec = ModelSpec(orders=(1, 2), lengthscale=0.2, signal_std=1.0, noise_std=0.02)
    cfg = SafeBOConfig(n_local=256, n_global=64, explore_from=explore_from, beta=2.0)
    bo = build_safe_bo(SafetyModel(spec, 3, 0.0), cfg, np.ones(3, dtype=bool), np.random.default_rng(0),
                       x0=np.array([0.2, 0.2, 0.2]), n_prior=n_prior)
    X = np.array([[0.22, 0.2, 0.21], [0.9, 0.9, 0.9], [0.2, 0.2, 0.2]])  # prior near, prior far, x0
    bo.fit(X, np.array([0.3, 0.9, 0.3]))
    return bo


def test_explore_from_x0_grows_the_search_region_from_the_start() -> None:
    bo = _prior_state("x0")
    np.testing.assert_array_equal(bo.region.connected(bo.obs), [True, False, True])
    far = np.array([0.9, 0.9, 0.9])
    for _ in range(5):
        mu_d, _, lcb_d, ucb_d = bo.bounds(bo.obs.X)
        assert not any(np.array_equal(a, far) for a in bo.region.anchors(bo.obs, lcb_d, ucb_d, bo.rng))
        p = bo.propose()
        assert np.linalg.norm(p.x - far) > 0.5
        bo.observe(p.x, 0.3)
    # Control: under "all" the far, better prior point is an anchor at once.
    bo = _prior_state("all")
    assert bo.region.connected(bo.obs).all()
    mu_d, _, lcb_d, ucb_d = bo.bounds(bo.obs.X)
    assert any(np.array_equal(a, far) for a in bo.region.anchors(bo.obs, lcb_d, ucb_d, bo.rng))


def test_exploitation_phase_takes_at_most_a_fifth_of_the_budget() -> None:
    r = ksbo_mav.optimize(additive_bumps, X0, BOUNDS, budget=10, method="standard", seed=0, exploit_last=20,
                          n_local=256, n_global=32)
    kinds = [p["kind"] for p in r.info["proposals"]]
    assert len(kinds) == 9  # x0 is the first of the 10 evaluations
    assert kinds[-2:] == ["exploit", "exploit"]
    assert "exploit" not in kinds[:-2]


def test_prior_points_chained_to_the_start_are_connected() -> None:
    """A resumed campaign passes its earlier trials as prior: a chain of small steps from x0 stays connected."""
    bo = _prior_state("x0", n_prior=6)
    chain = np.array([[0.2 + 0.08 * k, 0.2, 0.2] for k in range(1, 6)])  # 0.08 apart, up to 0.4 from x0
    X = np.vstack([chain, [[0.9, 0.9, 0.9]], [[0.2, 0.2, 0.2]]])
    bo.fit(X, np.full(7, 0.3))
    np.testing.assert_array_equal(bo.region.connected(bo.obs), [True] * 5 + [False, True])
