"""Adaptive safe BO: learned safety scale, trust region, censored aborts, max_aborts, re-flown recommendation with
its stress screen, evidence re-selection."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import ksbo_mav
from ksbo_mav.opt.models.failure_model import FailureModel, learn_scales
from ksbo_mav.opt.evaluation import Evaluation, Outcome
from ksbo_mav.opt.acquisition.trust_region import TrustRegion

CENTER = np.array([0.6, 0.45])
BOX2 = np.array([[0.0, 1.0]] * 2)
FIXED_SCALE = 0.05  # today's fixed safety lengthscale (Options.safety_lengthscale)


def bump(ell: float):
    """2-D Gaussian bump of width ``ell``: max 1 at CENTER, safe (≥ 0) within ≈1.18 ell of it."""

    def f(x: np.ndarray) -> float:
        return float(2.0 * np.exp(-np.sum((np.asarray(x) - CENTER) ** 2) / (2 * ell**2)) - 1.0)

    return f


def _run_bump(ell: float, learn: bool, seed: int = 0) -> tuple[ksbo_mav.OptimizeResult, float]:
    f = bump(ell)
    x0 = CENTER - np.array([1.0, 0.6]) * ell * 0.6  # f(x0) ≈ 0.57
    r = ksbo_mav.optimize(f, x0, BOX2, budget=40, method="safeopt", seed=seed, learn_safety_scale=learn,
                          signal_std=2.0, noise_std=1e-3, beta=3.0, n_local=512, n_global=64, recommend_noise=None,
                          safety_lengthscale=FIXED_SCALE, lengthscale=FIXED_SCALE, exploit_last=5)
    return r, f(r.x)


@pytest.mark.parametrize("factor", [5.0, 0.2])
def test_learned_safety_scale_follows_the_problem_and_stays_safe(factor: float) -> None:
    ell = FIXED_SCALE * factor
    r, f_rec = _run_bump(ell, learn=True)
    ls = np.asarray(r.info["safety_lengthscales"][-1])
    # The learnt scale moved from the fixed assumption towards the truth, in the right direction, on both axes.
    assert np.all(ls > 0.5 * ell) and np.all(ls < 2.5 * ell)
    assert r.n_unsafe == 0 and np.min(r.y) >= 0.0
    assert f_rec >= 0.95  # reached the optimum (max 1)


def test_fixed_scale_is_unsafe_on_the_small_scale_problem() -> None:
    """Control: the fixed lengthscale assumption queries unsafe points on the 5x smaller problem."""
    r, _ = _run_bump(FIXED_SCALE / 5, learn=False)
    assert r.n_unsafe > 0


def test_learnt_lengthscales_are_capped_by_the_data_extent() -> None:
    rng = np.random.default_rng(0)
    X = 0.5 + 0.01 * rng.standard_normal((6, 3))
    ls = learn_scales(X, np.full(6, 0.5), 1.0, 0.01, np.full(3, 0.05), extent_factor=2.0)[0]
    assert np.all(ls <= 2.0 * (X.max(0) - X.min(0)) + 1e-12)
    wide = learn_scales(X, np.full(6, 0.5), 1.0, 0.01, np.full(3, 0.05), extent_factor=None)[0]
    assert np.all(wide > ls)  # without the cap, a flat function claims long scales from a tiny cluster


def test_trust_region_grows_after_successes_and_shrinks_after_an_abort() -> None:
    tr = TrustRegion(radius=0.1, r_min=0.02, r_max=0.4, grow=2.0, shrink=0.5, success_tol=2)
    tr.update(Outcome.COMPLETE, improved=True)
    assert tr.radius == pytest.approx(0.1)  # one success is not enough
    tr.update(Outcome.COMPLETE, improved=True)
    assert tr.radius == pytest.approx(0.2)
    tr.update(Outcome.COMPLETE, improved=False)  # no improvement: unchanged
    assert tr.radius == pytest.approx(0.2)
    for _ in range(4):
        tr.update(Outcome.COMPLETE, improved=True)
    assert tr.radius == pytest.approx(0.4)  # capped at r_max
    tr.update(Outcome.ABORTED, improved=False)
    assert tr.radius == pytest.approx(0.2)
    tr.update(Outcome.COMPLETE, improved=True)
    tr.update(Outcome.CRASHED, improved=False)  # resets the success count too
    assert tr.radius == pytest.approx(0.1)
    tr.update(Outcome.COMPLETE, improved=True)
    assert tr.radius == pytest.approx(0.1)
    for _ in range(5):
        tr.update(Outcome.ABORTED, improved=False)
    assert tr.radius == pytest.approx(0.02)  # floored at r_min
    tr.center = np.array([0.5, 0.5])
    tr.set_weights(np.array([0.1, 0.4]))  # longer along the smoother dimension
    assert tr.contains(np.array([[0.5, 0.53], [0.53, 0.5]])).tolist() == [True, False]


def test_failure_model_learns_where_trials_abort() -> None:
    X = np.array([[0.2, 0.2], [0.22, 0.2], [0.8, 0.8], [0.82, 0.8]])
    fm = FailureModel(np.array([0.05, 0.05])).fit(X, np.array([0, 0, 1, 1], bool), np.array([0, 0, 0, 1], bool))
    p_abort, p_crash = fm.predict(np.array([[0.21, 0.2], [0.81, 0.8], [0.5, 0.5]]))
    assert p_abort[0] < 0.2 < p_abort[2] < p_abort[1]
    assert p_crash[0] < p_crash[1] and p_crash[1] > 0.2


def _aborting(region: float):
    """f on [0,1]^2: increases towards (1, 1); trials with x0 + x1 > region abort (censored)."""

    def f(x: np.ndarray) -> Evaluation | float:
        x = np.asarray(x)
        if x.sum() > region:
            return Evaluation(None, Outcome.ABORTED)
        return float(0.2 + 0.5 * x.sum() / 2)

    return f


@pytest.mark.parametrize("cap, backup_beta", [(0, None), (1, 1.0), (3, 1.0), (3, None)])
def test_max_aborts_is_never_exceeded(cap: int, backup_beta: float | None) -> None:
    r = ksbo_mav.optimize(_aborting(0.9), np.array([0.2, 0.2]), BOX2, budget=40, method="ksbo-adaptive", seed=cap,
                          max_aborts=cap, backup_beta=backup_beta, orders=(1, 2), n_local=256, n_global=0,
                          y_max=1.0)
    assert r.n_aborted + r.n_crashed <= cap
    if r.nfev < 40:  # the run ends exactly when the abort budget is spent
        assert r.n_aborted + r.n_crashed == cap and "max_aborts" in r.info["stopped"]
    assert r.outcomes[0] == "complete"


def test_aborted_trials_are_censored_not_values() -> None:
    calls = []

    def f(x: np.ndarray) -> Evaluation:
        calls.append(x)
        if x[0] > 0.45:
            return Evaluation(-123.0, Outcome.ABORTED)  # a made-up value the GP must never see
        return Evaluation(float(0.3 + x[0]), Outcome.COMPLETE)

    r = ksbo_mav.optimize(f, np.array([0.3, 0.5]), BOX2, budget=30, method="ksbo-adaptive", seed=1, max_aborts=5,
                          backup_beta=1.0,
                          orders=(1,), n_local=256, y_max=1.0)
    assert r.n_aborted >= 1
    assert np.all(r.y[np.array(r.outcomes) == "aborted"] == -123.0)  # recorded for the user ...
    gp_y = np.asarray(r.info["gp_train_y"])
    assert np.all(gp_y > -1.0)  # ... but never a training target
    assert len(gp_y) == sum(o == "complete" for o in r.outcomes)
    # Uncertified trials (covered by the backup) happened only while the abort budget lasted.
    kinds = [p["kind"] for p in r.info["proposals"]]
    outs = r.outcomes[1:]
    for i, k in enumerate(kinds):
        if k.endswith("/backup"):
            assert sum(o != "complete" for o in outs[:i]) < 5


def test_recommendation_refies_top_candidates_and_rejects_a_bistable_one() -> None:
    """B flew 1.0 once but aborts when re-flown; A flies 0.8 reliably: re-flying picks A."""
    from ksbo_mav.opt.method_config import AdaptiveConfig, SafeBOConfig
    from ksbo_mav.opt.models.safety_model import ModelSpec, SafetyModel
    from ksbo_mav.opt.methods.recommend import best_expected
    from ksbo_mav.opt.methods.build import build_safe_bo

    A, B, C = np.array([0.3, 0.3]), np.array([0.5, 0.6]), np.array([0.8, 0.2])
    model = SafetyModel(ModelSpec(orders=(2,), lengthscale=0.1, signal_std=1.0, noise_std=0.01), 2)
    bo = build_safe_bo(model, SafeBOConfig(recommend="mean", recommend_noise=None), np.ones(2, bool),
                np.random.default_rng(0), adaptive=AdaptiveConfig(refly_top=2))
    bo.fit(np.array([A, B, C]), np.array([0.8, 1.0, 0.3]))
    cands = bo.refly.pick_candidates(bo.criterion(), bo.obs, bo.certificate)
    assert sorted(cands.tolist()) == [0, 1]  # the two best distinct points, the lucky B included
    assert bo.recommend()[0] == 1  # without re-flying, the model would recommend B
    bo.observe(B, -1.0, Outcome.ABORTED)
    bo.observe(A, 0.8)
    bo.observe(B, 1.0)
    bo.observe(A, 0.79)
    assert best_expected(bo.obs, bo.certificate, cands) == 0


def test_after_a_failure_the_recommendation_weighs_each_candidates_failures() -> None:
    """B flew 0.95 twice but failed once when re-flown; A flew 0.8 four times and nobody failed near it. Ranked by
    the mean over its completed flights B would win; by expected score under the failure model A does. Control:
    the same flights with B's failure completed keep B."""
    from ksbo_mav.opt.method_config import AdaptiveConfig, SafeBOConfig
    from ksbo_mav.opt.models.safety_model import ModelSpec, SafetyModel
    from ksbo_mav.opt.methods.recommend import expected_value
    from ksbo_mav.opt.methods.build import build_safe_bo
    from ksbo_mav.opt.methods.safe_bo import SafeBO

    A, B = np.array([0.2, 0.3]), np.array([0.7, 0.7])

    def run(b_fails: bool) -> tuple[SafeBO, int]:
        model = SafetyModel(ModelSpec(orders=(2,), lengthscale=0.1, signal_std=1.0, noise_std=0.01), 2)
        bo = build_safe_bo(model, SafeBOConfig(recommend="mean", recommend_noise=None), np.ones(2, bool),
                    np.random.default_rng(0), adaptive=AdaptiveConfig(censor_aborts=True, refly_top=1))
        bo.fit(np.array([A, B]), np.array([0.8, 0.95]))
        for x, y in ((A, 0.8), (A, 0.81), (A, 0.79), (B, 0.95)):
            bo.observe(x, y)
        bo.observe(B, -1.0 if b_fails else 0.95, Outcome.ABORTED if b_fails else Outcome.COMPLETE)
        bo.refly.chosen = np.array([1])  # the re-fly phase chose B
        return bo, bo.final_choice()[0]

    bo, i = run(b_fails=True)
    assert np.array_equal(bo.obs.X[i], A)
    ev = [expected_value(bo.obs, bo.certificate, k) for k in (0, 1)]
    assert ev[1] < ev[0] < 0.8  # both discounted, B (1 failure in 3) far more
    bo, i = run(b_fails=False)
    assert np.array_equal(bo.obs.X[i], B)


def test_refly_phase_takes_the_last_evaluations() -> None:
    r = ksbo_mav.optimize(bump(0.2), np.array([0.5, 0.4]), BOX2, budget=20, method="ksbo-adaptive", seed=0,
                          refly_last=10, refly_top=2, orders=(1,), n_local=256, y_max=1.0)
    kinds = [p["kind"] for p in r.info["proposals"]]
    assert kinds[-2:] == ["refly"] * 2 and "refly" not in kinds[:-2]  # capped at a tenth of the budget
    reflown = np.array(r.info["reflown"])
    assert any(np.allclose(r.x, p) for p in reflown)


def test_orders_are_reselected_by_evidence_and_changes_reported() -> None:
    def additive(x: np.ndarray) -> float:  # order-1 structure: a sum of 1-D terms
        return float(0.5 + 0.3 * np.sum(np.sin(3 * np.asarray(x))) / 4)

    rng = np.random.default_rng(0)
    pX = 0.4 + 0.2 * rng.random((12, 4))
    prior = (pX, np.array([additive(x) for x in pX]))
    r = ksbo_mav.optimize(additive, np.full(4, 0.5), np.array([[0.0, 1.0]] * 4), budget=12, seed=0, prior=prior,
                          method="ksbo-adaptive", reselect_every=5, max_order=4, top=1, trials=20, n_local=128,
                          max_aborts=None, refly_last=0)
    assert r.info["selection"]["method"] == "cree"  # Algorithm 1 is the first selection
    res = r.info["reselections"]
    assert [s["at_iteration"] for s in res] == [5, 10]
    assert all(s["method"] == "evidence" and set(s["scores"]) == {1, 2, 3, 4} for s in res)
    assert r.info["reselection_changes"] == sum(s["changed"] for s in res)
    assert r.orders == tuple(res[-1]["orders"])


def test_ksbo_reselects_its_orders_every_10_iterations_by_default_and_0_keeps_the_papers_selection() -> None:
    def additive(x: np.ndarray) -> float:
        return float(0.5 + 0.3 * np.sum(np.sin(3 * np.asarray(x))) / 4)

    rng = np.random.default_rng(0)
    pX = 0.4 + 0.2 * rng.random((12, 4))
    prior = (pX, np.array([additive(x) for x in pX]))
    kw = dict(budget=22, seed=0, prior=prior, method="ksbo", max_order=4, trials=20, n_local=128)
    r = ksbo_mav.optimize(additive, np.full(4, 0.5), np.array([[0.0, 1.0]] * 4), **kw)
    assert r.info["selection"]["method"] == "cree"
    assert [s["at_iteration"] for s in r.info["reselections"]] == [10, 20]
    assert r.orders == tuple(r.info["reselections"][-1]["orders"])
    once = ksbo_mav.optimize(additive, np.full(4, 0.5), np.array([[0.0, 1.0]] * 4), reselect_every=0, **kw)
    assert "reselections" not in once.info
    assert once.orders == tuple(once.info["selection"]["orders"])


def test_monitor_outcomes_reach_the_result_counts() -> None:
    from ksbo_mav.simulated.planar_objective import SimObjective

    obj = SimObjective(seed=0, monitor=True)
    slow = np.array([0.15, 0.5, 0.1, 0.5, 0.0, 0.2, 3e4, 0.0, 1e4])
    X = [obj.profile.default, slow, slow]
    it = iter(X)
    r = ksbo_mav.optimize(lambda x: obj(next(it)), obj.profile.default, obj.profile.bounds, budget=3,
                          method="random", seed=0)
    assert r.outcomes[0] == "complete" and r.n_aborted == r.outcomes.count("aborted") >= 1
    assert r.n_crashed == r.outcomes.count("crashed") and r.n_unsafe >= r.n_aborted + r.n_crashed


# -- small-budget phases, re-fly candidates, fallback, backup trust ---------------------------------------------

def _adaptive_bo(**adaptive):
    from ksbo_mav.opt.method_config import AdaptiveConfig, SafeBOConfig
    from ksbo_mav.opt.models.safety_model import ModelSpec, SafetyModel
    from ksbo_mav.opt.methods.build import build_safe_bo

    model = SafetyModel(ModelSpec(orders=(2,), lengthscale=0.1, signal_std=1.0, noise_std=0.01), 2)
    return build_safe_bo(model, SafeBOConfig(recommend="mean", recommend_noise=None), np.ones(2, bool),
                  np.random.default_rng(0), adaptive=AdaptiveConfig(censor_aborts=True, **adaptive))


def test_fallback_never_refiles_a_point_the_failure_model_expects_to_abort() -> None:
    x0, B = np.array([0.2, 0.2]), np.array([0.7, 0.7])
    bo = _adaptive_bo()
    bo.fit(np.array([x0, B]), np.array([0.3, 0.9]))
    lcb_d = bo.bounds(bo.obs.X)[2]
    # control: B, the best LCB, while nothing failed there
    assert bo.region.fallback_index(bo.obs, lcb_d, bo.certificate) == 1
    bo.observe(B, -1.0, Outcome.ABORTED)  # the same gains aborted on the next flight (bistable)
    lcb_d = bo.bounds(bo.obs.X)[2]
    assert lcb_d[1] > lcb_d[0]  # the GP (completed trials only) still prefers B ...
    assert bo.region.fallback_index(bo.obs, lcb_d, bo.certificate) == 0  # ... the fallback goes back to x0


def test_refly_candidates_include_the_best_single_flight() -> None:
    from ksbo_mav.opt.method_config import AdaptiveConfig, SafeBOConfig
    from ksbo_mav.opt.models.safety_model import ModelSpec, SafetyModel
    from ksbo_mav.opt.methods.build import build_safe_bo

    rng = np.random.default_rng(1)
    cluster = 0.3 + 0.02 * rng.standard_normal((6, 2))
    lone = np.array([[0.8, 0.8]])  # the best flight, alone at the edge of the data
    X = np.vstack([cluster, lone])
    y = np.array([0.60, 0.61, 0.62, 0.60, 0.61, 0.62, 0.70])
    model = SafetyModel(ModelSpec(orders=(2,), lengthscale=0.1, signal_std=1.0, noise_std=0.01), 2)
    bo = build_safe_bo(model, SafeBOConfig(recommend="mean", recommend_noise=0.5), np.ones(2, bool),
                np.random.default_rng(0), adaptive=AdaptiveConfig(refly_top=2))
    bo.fit(X, y)
    mu, _ = bo.smoothed()
    assert 6 not in np.argsort(-mu)[:2]  # control: the smoothed criterion alone would not re-fly it
    assert 6 in bo.refly.pick_candidates(bo.criterion(), bo.obs, bo.certificate).tolist()


def test_short_budget_keeps_most_flights_for_the_search() -> None:
    def bowl(x: np.ndarray) -> float:
        return float(0.9 - np.sum((np.asarray(x) - CENTER) ** 2))

    # A fixed safety scale: the learnt one starts at 0.01 and would spend the first flights on fallbacks here.
    r = ksbo_mav.optimize(bowl, np.array([0.5, 0.5]), BOX2, budget=30, method="ksbo-adaptive", seed=0,
                          n_local=256, y_max=1.0, learn_safety_scale=False)
    kinds = [p["kind"] for p in r.info["proposals"]]
    assert kinds.count("expand") == 3 and kinds.count("refly") == 3  # a tenth of the budget each
    assert kinds.count("exploit") == 6  # a fifth


def test_backup_is_trusted_only_until_it_fails_to_recover() -> None:
    x0 = np.array([0.5, 0.5])
    bo = _adaptive_bo(backup_beta=0.5)
    bo.fit(np.array([x0, x0 + 0.01]), np.array([0.3, 0.31]))
    bo.remaining, bo.phases = 20, replace(bo.phases, budget=30)
    first = bo.propose()
    assert first.kind.endswith("/backup")  # control: uncertified but covered by the backup
    bo.observe(first.x, -1.0, Outcome.CRASHED)  # the backup did not recover
    for _ in range(3):
        p = bo.propose()
        assert not p.kind.endswith("/backup") and (p.kind == "fallback" or p.lcb >= bo.p_min)
        bo.observe(p.x, 0.3)


def test_exclusion_balls_grow_when_failures_cluster_and_stay_fixed_otherwise() -> None:
    """A second failure just outside the first one's ball (0.07 from it, radius 0.05) doubles both balls; a
    failure far away keeps its own base ball; growth 1 (the paper method) keeps every ball at the base radius."""
    from ksbo_mav.opt.acquisition.exclusion import exclusion_radii

    bad = np.array([[0.5, 0.5], [0.57, 0.5], [0.1, 0.9]])
    np.testing.assert_allclose(exclusion_radii(bad, 0.05, 2.0, 0.2), [0.1, 0.1, 0.05])
    np.testing.assert_allclose(exclusion_radii(bad, 0.05, 1.0, 0.2), [0.05] * 3)
    # a tight cluster: growth stops at the cap
    cluster = np.array([[0.5, 0.5], [0.55, 0.5], [0.5, 0.55], [0.55, 0.55], [0.45, 0.5]])
    assert exclusion_radii(cluster, 0.05, 2.0, 0.2).max() == pytest.approx(0.2)


def test_no_query_and_no_fallback_inside_a_grown_exclusion_ball() -> None:
    """After two clustered aborts, the state machine certifies nothing within the grown (0.1) ball of either,
    although the main GP never saw them (censored); the point 0.07 from the first abort was allowed before."""
    from ksbo_mav.opt.method_config import AdaptiveConfig, SafeBOConfig
    from ksbo_mav.opt.models.safety_model import ModelSpec, SafetyModel
    from ksbo_mav.opt.methods.build import build_safe_bo

    model = SafetyModel(ModelSpec(orders=(1, 2), lengthscale=0.3, signal_std=1.0, noise_std=0.01), 2)
    bo = build_safe_bo(model, SafeBOConfig(n_local=256, n_global=64, exclusion_radius=0.05), np.ones(2, bool),
                np.random.default_rng(0),
                adaptive=AdaptiveConfig(censor_aborts=True, exclusion_growth=2.0, exclusion_max=0.2))
    X = np.array([[0.3, 0.3], [0.35, 0.3], [0.3, 0.35], [0.4, 0.4], [0.45, 0.45]])
    bo.fit(X, np.array([0.5, 0.55, 0.55, 0.6, 0.65]))
    f1, f2, probe = np.array([0.5, 0.5]), np.array([0.57, 0.5]), np.array([[0.43, 0.5]])
    bo.observe(f1, -1.0, Outcome.ABORTED)
    assert not bo.certificate.exclusion.excluded(bo.obs, probe)[0]  # 0.07 from f1: outside its 0.05 ball
    bo.observe(f2, -1.0, Outcome.ABORTED)
    assert bo.certificate.exclusion.excluded(bo.obs, probe)[0] and not bo.safe_mask(probe)[0]
    for _ in range(5):
        p = bo.propose()
        assert min(np.linalg.norm(p.x - f1), np.linalg.norm(p.x - f2)) >= 0.1 - 1e-12
        bo.observe(p.x, 0.6)


def test_a_failure_at_new_gains_shrinks_the_learnt_safety_scale_a_failed_reflight_does_not() -> None:
    """The SE-ARD GP here has orders (d,), so it is the scale model; its ML-II lengthscales are multiplied by
    ``failure_scale_shrink`` per failure at new gains (the certified region shrinks), not for a failed re-flight."""
    from ksbo_mav.opt.method_config import AdaptiveConfig, SafeBOConfig
    from ksbo_mav.opt.models.safety_model import ModelSpec, SafetyModel
    from ksbo_mav.opt.methods.build import build_safe_bo
    from ksbo_mav.opt.methods.safe_bo import SafeBO

    rng = np.random.default_rng(1)
    X = 0.4 + 0.2 * rng.random((12, 2))
    y = 0.5 + 0.3 * np.sin(3 * X[:, 0]) * np.cos(2 * X[:, 1])

    def state(shrink: float) -> SafeBO:
        model = SafetyModel(ModelSpec(orders=(2,), lengthscale=0.1, signal_std=1.0, noise_std=0.01), 2)
        bo = build_safe_bo(model, SafeBOConfig(), np.ones(2, bool), np.random.default_rng(0),
                    adaptive=AdaptiveConfig(censor_aborts=True, learn_safety_scale=True,
                                            failure_scale_shrink=shrink))
        bo.fit(X, y)
        return bo

    bo, ref = state(0.5), state(1.0)
    base = np.asarray(bo.model.spec.lengthscale, float)
    np.testing.assert_allclose(base, ref.model.spec.lengthscale)
    for b in (bo, ref):
        b.observe(np.array([0.7, 0.7]), -1.0, Outcome.CRASHED)  # new gains
    np.testing.assert_allclose(bo.model.spec.lengthscale, np.maximum(0.5 * base, 0.01))
    np.testing.assert_allclose(ref.model.spec.lengthscale, base)
    bo.observe(X[3], -1.0, Outcome.ABORTED)  # a re-flight of flown gains: no new information on the scale
    np.testing.assert_allclose(bo.model.spec.lengthscale, np.maximum(0.5 * base, 0.01))
    assert bo.surrogate.scale.factor == 0.5


def test_an_unsafe_flight_at_new_gains_shrinks_a_fixed_safety_scale_a_safe_one_or_a_reflight_does_not() -> None:
    """Strict mode (no monitor, no learnt scale): ``unsafe_scale_shrink`` multiplies the fixed lengthscale of the
    local safety GP per completed flight below p_min at new gains; a safe flight and an unsafe re-flight of flown
    gains leave it. The additive main GP keeps its own lengthscale."""
    from ksbo_mav.opt.method_config import AdaptiveConfig, SafeBOConfig
    from ksbo_mav.opt.models.safety_model import ModelSpec, SafetyModel
    from ksbo_mav.opt.methods.build import build_safe_bo
    from ksbo_mav.opt.methods.safe_bo import SafeBO

    rng = np.random.default_rng(1)
    X = 0.4 + 0.2 * rng.random((12, 3))
    y = 0.5 + 0.3 * np.sin(3 * X[:, 0]) * np.cos(2 * X[:, 1])

    def state(shrink: float) -> SafeBO:
        model = SafetyModel(ModelSpec(orders=(1, 2), lengthscale=0.1, signal_std=1.0, noise_std=0.01), 3)
        safety = SafetyModel(ModelSpec(orders=(3,), lengthscale=0.06, signal_std=1.0, noise_std=0.01), 3)
        bo = build_safe_bo(model, SafeBOConfig(), np.ones(3, bool), np.random.default_rng(0), safety_model=safety,
                    adaptive=AdaptiveConfig(unsafe_scale_shrink=shrink))
        bo.fit(X, y)
        return bo

    bo, ref = state(0.7), state(1.0)
    for b in (bo, ref):
        b.observe(np.array([0.45, 0.5, 0.55]), 0.4)  # safe, new gains
    assert bo.surrogate.scale.factor == 1.0 and bo.surrogate.safety_model.spec.lengthscale == 0.06
    for b in (bo, ref):
        b.observe(np.array([0.7, 0.7, 0.7]), -0.5)  # unsafe, new gains
    np.testing.assert_allclose(bo.surrogate.safety_model.spec.lengthscale, [0.042] * 3)
    assert ref.surrogate.safety_model.spec.lengthscale == 0.06 and ref.surrogate.scale.factor == 1.0
    assert bo.model.spec.lengthscale == 0.1
    bo.observe(np.array([0.7, 0.7, 0.7]), -0.6)  # the same gains again: no new information on the scale
    np.testing.assert_allclose(bo.surrogate.safety_model.spec.lengthscale, [0.042] * 3)
    bo.observe(np.array([0.3, 0.7, 0.7]), -0.2)  # unsafe at new gains again
    np.testing.assert_allclose(bo.surrogate.safety_model.spec.lengthscale, [0.0294] * 3)
    # the shrunk GP is the one that certifies: its posterior is that of a fresh fit at the shrunk scale
    fresh = SafetyModel(ModelSpec(orders=(3,), lengthscale=(0.0294,) * 3, signal_std=1.0, noise_std=0.01), 3)
    fresh.fit(bo.obs.X, bo.obs.y)
    Z = rng.random((5, 3))
    np.testing.assert_allclose(bo.surrogate.safety_model.predict(Z)[0], fresh.predict(Z)[0], atol=1e-9)


def test_a_refly_candidate_that_fails_is_not_flown_again() -> None:
    """Re-fly phase of 6 flights over 2 candidates: B aborts at its first re-flight, so the rest go to A."""
    from ksbo_mav.opt.method_config import AdaptiveConfig, SafeBOConfig
    from ksbo_mav.opt.models.safety_model import ModelSpec, SafetyModel
    from ksbo_mav.opt.methods.build import build_safe_bo

    A, B = np.array([0.2, 0.3]), np.array([0.7, 0.7])
    model = SafetyModel(ModelSpec(orders=(2,), lengthscale=0.1, signal_std=1.0, noise_std=0.01), 2)
    bo = build_safe_bo(model, SafeBOConfig(recommend="mean", recommend_noise=None), np.ones(2, bool),
                np.random.default_rng(0), adaptive=AdaptiveConfig(censor_aborts=True, refly_top=2))
    bo.fit(np.array([A, B]), np.array([0.8, 0.95]))
    bo.refly.chosen = np.array([1, 0])
    flown = []
    for k in range(6):
        i = bo.refly.next_flight(k, bo.criterion, bo.obs, bo.certificate)[0]
        flown.append("A" if np.array_equal(bo.obs.X[i], A) else "B")
        bad = flown[-1] == "B"
        bo.observe(bo.obs.X[i], -1.0 if bad else 0.8, Outcome.ABORTED if bad else Outcome.COMPLETE)
    assert flown == ["B", "A", "A", "A", "A", "A"]


def test_when_every_refly_candidate_failed_the_best_point_clear_of_failures_is_flown() -> None:
    """Only B is a candidate and it aborts: the next re-flights go to A (4 clean flights, far from B), which
    joins the re-flown set; the final choice is A."""
    from ksbo_mav.opt.method_config import AdaptiveConfig, SafeBOConfig
    from ksbo_mav.opt.models.safety_model import ModelSpec, SafetyModel
    from ksbo_mav.opt.methods.build import build_safe_bo

    A, B = np.array([0.2, 0.3]), np.array([0.7, 0.7])
    model = SafetyModel(ModelSpec(orders=(2,), lengthscale=0.1, signal_std=1.0, noise_std=0.01), 2)
    bo = build_safe_bo(model, SafeBOConfig(recommend="mean", recommend_noise=None), np.ones(2, bool),
                np.random.default_rng(0), adaptive=AdaptiveConfig(censor_aborts=True, refly_top=1))
    bo.fit(np.array([A, A, A, A, B]), np.array([0.8, 0.8, 0.8, 0.8, 0.95]))
    bo.refly.chosen = np.array([4])
    assert np.array_equal(bo.obs.X[bo.refly.next_flight(0, bo.criterion, bo.obs, bo.certificate)[0]], B)
    bo.observe(B, -1.0, Outcome.ABORTED)
    i = bo.refly.next_flight(1, bo.criterion, bo.obs, bo.certificate)[0]
    assert np.array_equal(bo.obs.X[i], A) and i in bo.refly.chosen
    bo.observe(A, 0.8)
    assert np.array_equal(bo.obs.X[bo.final_choice()[0]], A)


def test_ard_acquisition_stops_paying_for_uncertainty_along_flat_dimensions() -> None:
    """``ard_acquisition``: the UCB's GP takes the learnt safety lengthscales where they are longer than the main
    GP's, so a step along a dimension the data show to be flat earns less UCB than the same step along the one that
    matters; the safety bound (LCB) is the main and safety GPs' and does not change."""
    from ksbo_mav.opt.method_config import AdaptiveConfig, SafeBOConfig
    from ksbo_mav.opt.models.safety_model import ModelSpec, SafetyModel
    from ksbo_mav.opt.methods.build import build_safe_bo
    from ksbo_mav.opt.methods.safe_bo import SafeBO

    rng = np.random.default_rng(3)
    X = 0.3 + 0.4 * rng.random((40, 3))
    y = 0.4 + 0.3 * np.sin(15 * X[:, 0])  # only x0 matters

    def state(ard: float) -> SafeBO:
        spec = ModelSpec(orders=(1, 2), lengthscale=0.1, signal_std=1.0, noise_std=0.01)
        safety = SafetyModel(ModelSpec(orders=(3,), lengthscale=0.05, signal_std=1.0, noise_std=0.01), 3)
        bo = build_safe_bo(SafetyModel(spec, 3), SafeBOConfig(), np.ones(3, bool), np.random.default_rng(0),
                    safety_model=safety, adaptive=AdaptiveConfig(learn_safety_scale=True, ard_acquisition=ard))
        bo.fit(X, y)
        return bo

    bo, ref = state(1.0), state(0.0)
    assert ref.surrogate.acq_model is None
    ls = np.asarray(bo.surrogate.acq_model.spec.lengthscale)
    assert np.all(ls >= 0.1) and np.all(ls[1:] > 3 * ls[0])  # flat dimensions stretched far more than x0
    Z = np.array([[0.5, 0.5, 0.5]] * 3) + 0.35 * np.eye(3)  # the same step out of the data along each axis
    _, sd, lcb, up = bo.bounds(Z)
    _, _, lcb_ref, up_ref = ref.bounds(Z)
    np.testing.assert_allclose(lcb, lcb_ref)
    np.testing.assert_allclose(sd, sd[0], rtol=0.2)  # the main GP's uncertainty: the same along every axis ...
    _, sd_acq = bo.surrogate.acq_model.predict(Z)
    assert np.all(sd_acq[1:] < 0.5 * sd_acq[0])  # ... the acquisition GP's: small along the flat ones
    mu_acq, _ = bo.surrogate.acq_model.predict(Z)
    np.testing.assert_allclose(up, mu_acq + bo.certificate.beta_ucb * sd_acq)  # and the UCB is the acquisition GP's
    x_new = np.array([0.45, 0.55, 0.5])
    bo.observe(x_new, 0.4 + 0.3 * np.sin(15 * 0.45))  # the acquisition GP takes new data like the others
    assert bo.surrogate.acq_model.n == bo.model.n == 41


def test_a_lucky_flight_does_not_stop_the_trust_region_growing() -> None:
    """The lucky point flew 0.95 once; two neighbouring trials at 0.92 and 0.94 are the better region by the
    posterior mean though neither beats 0.95 as flown. The second becomes the incumbent: a success, and the region
    grows (one success grows it here). A trial that does not become the incumbent is no success."""
    from ksbo_mav.opt.methods.build import build_safe_bo
    from ksbo_mav.opt.method_config import AdaptiveConfig, SafeBOConfig
    from ksbo_mav.opt.models.safety_model import ModelSpec, SafetyModel

    model = SafetyModel(ModelSpec(orders=(2,), lengthscale=0.1, signal_std=1.0, noise_std=0.3), 2)
    bo = build_safe_bo(model, SafeBOConfig(), np.ones(2, bool), np.random.default_rng(0),
                       adaptive=AdaptiveConfig(trust_region=True, tr_success=1))
    lucky = np.array([0.8, 0.5])
    bo.fit(np.array([[0.5, 0.5], lucky]), np.array([0.5, 0.95]))
    bo.observe(np.array([0.3, 0.5]), 0.92)
    np.testing.assert_array_equal(bo.trust_region.center, lucky)  # not yet the better region by the mean
    assert bo.trust_region.radius == pytest.approx(0.1)
    bo.observe(np.array([0.3, 0.55]), 0.94)
    np.testing.assert_array_equal(bo.trust_region.center, [0.3, 0.55])
    assert bo.trust_region.radius == pytest.approx(0.2)


def test_the_trust_region_centre_is_never_inside_a_failures_exclusion_ball() -> None:
    """A flew 0.9 and is the best point, but a trial 0.02 from it crashed: with growing balls the trust region
    centres on B (0.6, clear of failures) instead. A centre inside a ball wider than the trust region left no
    candidate to query: a 200-flight nominal run re-flew one point near a0 for its last ~80 flights. Control:
    fixed balls keep A."""
    from ksbo_mav.opt.method_config import AdaptiveConfig, SafeBOConfig
    from ksbo_mav.opt.models.safety_model import ModelSpec, SafetyModel
    from ksbo_mav.opt.methods.build import build_safe_bo

    A, B = np.array([0.6, 0.6]), np.array([0.3, 0.3])

    def centre(growth: float) -> np.ndarray:
        model = SafetyModel(ModelSpec(orders=(2,), lengthscale=0.1, signal_std=1.0, noise_std=0.01), 2)
        bo = build_safe_bo(model, SafeBOConfig(), np.ones(2, bool), np.random.default_rng(0),
                    adaptive=AdaptiveConfig(censor_aborts=True, trust_region=True, exclusion_growth=growth))
        bo.fit(np.array([B, A]), np.array([0.6, 0.9]))
        assert np.array_equal(bo.trust_region.center, A)  # before any failure: the best point
        bo.observe(A + np.array([0.02, 0.0]), -1.0, Outcome.CRASHED)
        return bo.trust_region.center

    np.testing.assert_array_equal(centre(2.0), B)
    np.testing.assert_array_equal(centre(1.0), A)


def test_a_scale_refit_fits_the_safety_gp_once_and_matches_a_fresh_fit(monkeypatch) -> None:
    """The safety GP is fitted once per refit of its learnt scale (the fit before the scale was learnt only fixed
    its signal and noise scales on the first call), and the posterior is that of a fresh fit with the learnt
    lengthscales."""
    from ksbo_mav.opt.method_config import AdaptiveConfig, SafeBOConfig
    from ksbo_mav.opt.models.safety_model import ModelSpec, SafetyModel
    from ksbo_mav.opt.methods.build import build_safe_bo

    rng = np.random.default_rng(5)
    X = 0.4 + 0.2 * rng.random((30, 3))
    y = 0.5 + 0.2 * np.sin(10 * X[:, 0])
    safety = SafetyModel(ModelSpec(orders=(3,), lengthscale=0.05, noise_std=None), 3)
    bo = build_safe_bo(SafetyModel(ModelSpec(orders=(1, 2), lengthscale=0.1), 3), SafeBOConfig(), np.ones(3, bool),
                np.random.default_rng(0), safety_model=safety,
                adaptive=AdaptiveConfig(learn_safety_scale=True, scale_refit_every=1))
    bo.fit(X, y)
    fits: list[int] = []
    real_fit = SafetyModel.fit

    def counting_fit(self, X_, y_):
        fits.append(id(self))
        return real_fit(self, X_, y_)

    monkeypatch.setattr(SafetyModel, "fit", counting_fit)
    x_new = np.array([0.5, 0.45, 0.55])
    bo.observe(x_new, 0.5 + 0.2 * np.sin(5.0))  # iteration 1 <= 4 * scale_refit_every: a scale refit
    assert len(bo.surrogate.scale.history) == 2
    assert fits.count(id(bo.surrogate.safety_model)) == 1
    fresh = bo.surrogate.safety_model.variant(lengthscale=bo.surrogate.safety_model.spec.lengthscale)
    real_fit(fresh, bo.obs.X, bo.obs.y)
    Z = 0.3 + 0.4 * rng.random((20, 3))
    for a, b in zip(bo.surrogate.safety_model.predict(Z), fresh.predict(Z)):
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12)


def test_the_failure_model_takes_every_trial_not_only_those_that_trigger_a_refit() -> None:
    """A completed trial that updates the GPs rank-one (no refit) joins the failure records too, so P(abort)
    next to an earlier abort falls as soon as flights there complete."""
    x0, B = np.array([0.2, 0.2]), np.array([0.6, 0.6])
    bo = _adaptive_bo()
    bo.fit(np.array([x0, [0.3, 0.3]]), np.array([0.3, 0.5]))
    bo.observe(B, -1.0, Outcome.ABORTED)
    p_before = bo.certificate.failures.predict(B[None, :])[0][0]
    for dx in (0.01, -0.01, 0.02):
        bo.observe(B + dx, 0.6)  # completed, no refit (scale learning off, refit_every 0)
    assert bo.certificate.failures.X.shape[0] == bo.obs.X.shape[0] == 6
    assert bo.certificate.failures.predict(B[None, :])[0][0] < 0.6 * p_before


# -- the re-fly phase's stress screen ---------------------------------------------------------------------------

class _Stressed:
    """bump(0.2) whose first candidate fails from the hardest start (``stress``): bistable gains that ordinary
    flights cannot tell from the others."""

    def __init__(self) -> None:
        self.f, self.stress_calls = bump(0.2), []

    def __call__(self, x: np.ndarray) -> float:
        return self.f(x)

    def stress(self, x: np.ndarray) -> Evaluation:
        self.stress_calls.append(np.array(x, dtype=float))
        ok = not np.array_equal(self.stress_calls[0], x)
        return Evaluation(self.f(x), Outcome.COMPLETE) if ok else Evaluation(None, Outcome.ABORTED)


def test_refly_stress_screens_candidates_from_the_hardest_start_then_reflies_those_that_passed() -> None:
    kw = dict(budget=40, method="ksbo-adaptive", seed=0, refly_last=4, refly_top=2, orders=(1,), n_local=256,
              y_max=1.0)
    fun = _Stressed()
    r = ksbo_mav.optimize(fun, np.array([0.5, 0.4]), BOX2, refly_stress=True, **kw)
    kinds = [p["kind"] for p in r.info["proposals"]]
    n_stress = kinds.count("stress")
    assert n_stress == len(fun.stress_calls) >= 1 and n_stress + kinds.count("refly") == 4
    assert kinds[-4:].count("stress") == n_stress  # all in the re-fly phase, the last 4 evaluations
    assert len({tuple(c) for c in fun.stress_calls}) == n_stress  # each candidate is screened once
    assert all(any(np.array_equal(c, x) for x in r.X[:-4]) for c in fun.stress_calls)  # flown gains
    failed, passed = fun.stress_calls[0], fun.stress_calls[1:]
    assert passed  # the first candidate failed, so the next was screened
    assert any(np.array_equal(r.x, c) for c in passed) and not np.array_equal(r.x, failed)
    refl = [x for x, k in zip(r.X[-4:], kinds[-4:]) if k == "refly"]  # ordinary re-flights: survivors only
    assert refl and all(any(np.array_equal(x, c) for c in passed) for x in refl)
    plain = _Stressed()
    ksbo_mav.optimize(plain, np.array([0.5, 0.4]), BOX2, refly_stress=False, **kw)
    assert plain.stress_calls == []  # off: the re-flights are ordinary flights
    default = _Stressed()
    ksbo_mav.optimize(default, np.array([0.5, 0.4]), BOX2, **kw)
    assert len(default.stress_calls) == n_stress  # ksbo-adaptive screens by default
    # an objective without `stress` re-flies as usual under refly_stress
    r2 = ksbo_mav.optimize(bump(0.2), np.array([0.5, 0.4]), BOX2, **kw)
    assert [p["kind"] for p in r2.info["proposals"]].count("refly") == 4


