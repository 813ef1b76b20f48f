"""Safe Bayesian optimisation in the unit cube: safe set from the GP's lower bound, local candidates, two rules.

Safe set S_n = {x : LCB_n(x) = μ_n(x) − β σ_n(x) ≥ p_min}, with σ the *marginal* posterior std (a joint
posterior over thousands of candidates is never formed; SafeCtrlBO's pitfall 2). Candidates are Gaussian clouds
around certified-safe observations plus a global Sobol set, refined by a constrained local search, so the safe
region is reachable in 9-D (pitfall 4). Two acquisition rules:

* ``"ucb"`` — SafeCtrlBO's rule with its bug fixed: for the first ``expansion_iters`` *BO iterations* (not total
  observations, pitfall 3) the most uncertain safe candidate near the safety boundary is evaluated, afterwards the
  safe UCB maximiser (the phases, and the final exploitation: opt.phases).
* ``"safeopt"`` — SafeOpt's rule: the widest confidence interval among the plausible maximisers
  M = {x ∈ S : UCB(x) ≥ max_S LCB} and the boundary points (SafeOptSwarm-style stand-in for SafeOpt's expanders,
  which would need one GP update per expander candidate).

If no candidate is certified safe the observation with the largest LCB is re-evaluated (a *fallback*); with a
known-safe start this is always a point that was safe before.

With an :class:`AdaptiveConfig` (issue 13) the state machine also learns the safety GP's lengthscales (and
takes its UCB from a GP stretched along the dimensions they show to be flat; opt.scale), keeps a trust region,
and — while the abort budget lasts — queries points the backup covers (certified with ``backup_beta``, low
predicted abort/crash probability). Aborted and crashed trials are censored: they enter the
failure model and the exclusion balls, never the GPs as values. Re-fly phase and recommendation: opt.recommend.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ksbo_mav.opt.acquisition import BoundaryExpansion
from ksbo_mav.opt import lines, lipschitz, phases, recommend, region, scale, symptom_rule
from ksbo_mav.opt.calibration import BetaCalibration
from ksbo_mav.opt.candidates import refine
from ksbo_mav.opt.config import AdaptiveConfig, SafeBOConfig
from ksbo_mav.opt.failure_model import FailureModel
from ksbo_mav.opt.model import SafetyModel
from ksbo_mav.opt.trust_region import TrustRegion
from ksbo_mav.opt.outcome import Outcome

RULES = ("ucb", "safeopt")


@dataclass
class Proposal:
    """One proposed query: x (d,) unit cube, its posterior summary and how it was chosen."""

    x: np.ndarray
    # "expand" | "ucb" | "safeopt" | "line" | "symptom" | "exploit" | "fallback" | "refly" | "stress" (+ "/backup"
    # if not certified)
    kind: str
    mu: float
    sd: float
    lcb: float


@dataclass
class SafeBO:
    """Safe BO state machine: ``propose`` → evaluate → ``observe``; the caller owns the evaluations."""

    model: SafetyModel
    config: SafeBOConfig
    free: np.ndarray  # (d,) bool: dimensions the optimiser may move (others stay at the start value)
    rng: np.random.Generator
    x0: np.ndarray | None = None  # (d,) start; fixed dimensions take its values (default: first data point)
    safety_model: SafetyModel | None = None  # optional second GP whose LCB must also clear p_min
    n_prior: int = 0  # leading rows of the data that are prior (not evaluated by this optimiser)
    budget: int = 0  # evaluations of the whole run (caps the exploitation phase); 0 = unknown, no cap
    adaptive: AdaptiveConfig = field(default_factory=AdaptiveConfig)
    X: np.ndarray = field(init=False)  # (n, d) every trial, prior first
    y: np.ndarray = field(init=False)  # (n,) values; censored trials hold a value below p_min
    complete: np.ndarray = field(init=False)  # (n,) bool: completed trials (the GPs' data)
    crashed: np.ndarray = field(init=False)  # (n,) bool
    iteration: int = field(default=0, init=False)
    fallbacks: int = field(default=0, init=False)
    remaining: int | None = field(default=None, init=False)  # evaluations left, set by the driver loop
    relaxed: bool = field(default=False, init=False)  # this proposal may use the backup (abort budget left)
    tr: TrustRegion | None = field(default=None, init=False)
    failures: FailureModel | None = field(default=None, init=False)
    scale_history: list[list[float]] = field(default_factory=list, init=False)  # learnt (d,) lengthscales
    refly_set: np.ndarray | None = field(default=None, init=False)  # (k,) data indices re-flown (opt.runner)
    stress_passed: dict[int, bool] = field(default_factory=dict, init=False)  # refly_stress results (opt.stress)
    scale_factor: float = field(default=1.0, init=False)  # learnt safety scale × this (shrinks on new failures)
    ml_scale: np.ndarray | None = field(default=None, init=False)  # (d,) last marginal-likelihood lengthscales
    fixed_scale: np.ndarray | None = field(default=None, init=False)  # (d,) configured scale, once it shrank
    acq_model: SafetyModel | None = field(default=None, init=False)  # main GP stretched along flat dimensions
    noise_floor: float | None = field(default=None, init=False)  # the safety GP's fixed noise std (learnt above it)
    calibration: BetaCalibration = field(init=False)  # one-step-ahead scores of the bound; the β they support
    n_lines: int = field(default=0, init=False)  # coordinate lines flown (``line_every``; opt.lines)
    symptoms: list[dict[str, float] | None] | None = None  # per evaluation of the run (Problem.symptoms)

    def __post_init__(self) -> None:
        if self.config.rule not in RULES:
            raise ValueError(f"unknown rule {self.config.rule!r}; expected one of {RULES}")
        self.X = np.zeros((0, self.model.dim))
        self.y = np.zeros(0)
        self.complete = np.zeros(0, dtype=bool)
        self.crashed = np.zeros(0, dtype=bool)
        c = self.config
        self.calibration = BetaCalibration(c.beta, c.beta_min, c.beta_quantile, c.beta_margin, c.beta_min_points,
                                           c.beta_window, c.beta_cap)
        a = self.adaptive
        if a.trust_region:
            self.tr = TrustRegion(a.tr_init, a.tr_min, a.tr_max, a.tr_grow, a.tr_shrink, a.tr_success)

    # -- data ---------------------------------------------------------------------------------------------------
    @property
    def gp_mask(self) -> np.ndarray:
        """(n,) bool: trials the GPs are trained on — completed ones when aborts are censored, else all (an aborted
        trial then enters with its recorded value, the behaviour of the paper's method)."""
        return self.complete if self.adaptive.censor_aborts else np.ones_like(self.complete)

    @property
    def aborts(self) -> int:
        """Trials of this run that aborted or crashed (prior excluded)."""
        return int(np.sum(~self.complete[self.n_prior :]))

    def fit(self, X: np.ndarray, y: np.ndarray, complete: np.ndarray | None = None,
            crashed: np.ndarray | None = None) -> None:
        """Fit on all data so far: X (n, d) unit cube, y (n,), optional (n,) bool outcome masks."""
        self.X = np.asarray(X, dtype=float).reshape(-1, self.model.dim)
        self.y = np.asarray(y, dtype=float).reshape(-1)
        n = self.y.size
        self.complete = np.ones(n, dtype=bool) if complete is None else np.asarray(complete, dtype=bool)
        self.crashed = np.zeros(n, dtype=bool) if crashed is None else np.asarray(crashed, dtype=bool)
        if self.x0 is None:
            self.x0 = self.X[0].copy()
        target = self._scale_model()
        if self.adaptive.learn_safety_scale and target is not None:
            target.spec = target.spec.with_(lengthscale=float(max(self.adaptive.safety_scale_bounds[0],
                                                                   self.adaptive.safety_scale_floor)))
        self._refit(learn=self.adaptive.learn_safety_scale)
        if self.tr is not None:
            self.tr.center = region.incumbent(self)

    def _refit(self, learn: bool = False) -> None:
        Xc, yc = self.X[self.gp_mask], self.y[self.gp_mask]
        target = self._scale_model()
        # relearn refits the scale model with its new lengthscales; a fit before that only fixes its signal and
        # noise scales (first call), so later calls skip it (an O(n^3) fit per refit).
        skip = target is not None and np.isfinite(target.signal_std) and scale.refits(self, learn, yc.size)
        for m in (self.model, self.safety_model):
            if m is not None and not (skip and m is target):
                m.fit(Xc, yc)
        if target is not None:
            scale.relearn(self, target, Xc, yc, learn)
        if self.tr is not None and target is not None and np.ndim(target.spec.lengthscale):
            self.tr.set_weights(np.asarray(target.spec.lengthscale, dtype=float))
        self.refresh_acquisition()
        if self.adaptive.backup_beta is not None or self.adaptive.censor_aborts:
            self.failures = FailureModel(self._safety_lengthscales()).fit(self.X, ~self.complete, self.crashed)

    def refresh_acquisition(self) -> None:
        """Rebuild the acquisition GP from the current data and learnt scale (opt.scale.acquisition_model)."""
        self.acq_model = scale.acquisition_model(self)

    def _scale_model(self) -> SafetyModel | None:
        """The SE-ARD GP whose lengthscales are the safety scale (the safety GP, or an SE-ARD main model)."""
        if self.safety_model is not None:
            return self.safety_model
        return self.model if tuple(self.model.spec.orders) == (self.model.dim,) else None

    def _safety_lengthscales(self) -> np.ndarray:
        m = self._scale_model() or self.model
        return np.broadcast_to(np.asarray(m.spec.lengthscale, dtype=float), (self.model.dim,)).copy()

    def observe(self, x: np.ndarray, y: float, outcome: Outcome = Outcome.COMPLETE) -> None:
        """Add one trial and advance the BO iteration counter (which keys the expansion phase).

        A completed trial updates the GPs (rank-one, or a full refit every ``refit_every`` iterations; the safety
        scale is relearnt every ``scale_refit_every``); an aborted or crashed one only the failure records.
        """
        self.iteration += 1
        done = outcome is Outcome.COMPLETE
        self.calibration.observed(x, y)
        # A failure at new gains that the safety GP had certified (or the backup covered): the safety scale
        # claimed too much smoothness here, so it shrinks (re-flights of flown gains say nothing about the scale).
        # In strict mode an unsafe (P < p_min) completed flight is the same evidence without a monitor.
        if not done:
            shrink = self.adaptive.failure_scale_shrink
        elif y < self.p_min and self._scale_model() is not None:
            shrink = self.adaptive.unsafe_scale_shrink
        else:
            shrink = 1.0
        novel = not bool(np.all(self.X == np.asarray(x, float).reshape(1, -1), axis=1).any())
        shrunk = novel and shrink < 1.0
        if shrunk:
            self.scale_factor *= shrink
        best_before = float(np.max(self.y[self.complete], initial=-np.inf))
        self.X = np.vstack([self.X, np.asarray(x, float).reshape(1, -1)])
        self.y = np.append(self.y, float(y))
        self.complete = np.append(self.complete, done)
        self.crashed = np.append(self.crashed, outcome is Outcome.CRASHED)
        k, a = self.config.refit_every, self.adaptive
        # The ML-II refit interval grows with the data (every 5 up to 100 trials, 10 at 200): a fit costs O(n^3)
        # per step while one more trial moves the optimum less and less.
        every = max(a.scale_refit_every, self.y.size // 20) if a.scale_refit_every > 0 else 0
        learn = a.learn_safety_scale and every > 0 and (self.iteration <= 4 * a.scale_refit_every
                                                         or self.iteration % every == 0)
        if learn or shrunk or (k and self.iteration % k == 0) or (not done and (self.failures is not None
                                                                                or a.failure_scale_shrink < 1.0)):
            self._refit(learn=learn)
        else:
            if done or not a.censor_aborts:
                for m in (self.model, self.safety_model, self.acq_model):
                    if m is not None:
                        m.add(x, y)
            if self.failures is not None:
                # Every trial joins the failure records at once (they used to wait for the next refit): a success
                # next to a failure lowers its predicted P(abort) for the very next proposal.
                self.failures.fit(self.X, ~self.complete, self.crashed)
        if self.tr is not None:
            self.tr.update(outcome, done and y >= self.p_min and y > best_before)
            self.tr.center = region.incumbent(self)

    # -- posterior ----------------------------------------------------------------------------------------------
    @property
    def p_min(self) -> float:
        return self.model.p_min

    @property
    def beta(self) -> float:
        """The safety β in force: the configured one, or the calibrated one (``beta_min``; opt.calibration)."""
        return self.calibration.beta()

    def _capped(self, Xc: np.ndarray, main: tuple[np.ndarray, np.ndarray] | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
        """Each model's capped mean and std at Xc (m, d) — the parts of the LCB; two (k, m) arrays (main model
        first, then the safety model). ``main``: the main model's (mean, std) at Xc if already predicted."""
        yc = self.y[self.gp_mask]
        cap = yc.max() if self.config.cap_mean and yc.size else np.inf
        if self.config.y_max is not None:
            cap = min(cap, self.config.y_max)
        pairs = [main if main is not None else self.model.predict(Xc)]
        if self.safety_model is not None:
            pairs.append(self.safety_model.predict(Xc))
        return np.array([np.minimum(mu, cap) for mu, _ in pairs]), np.array([sd for _, sd in pairs])

    def bounds(self, Xc: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Posterior mean, marginal std, LCB (safety β) and UCB (acquisition β) at Xc (m, d); four (m,) arrays.

        With a ``safety_model`` the LCB is the smaller of both models' bounds (a point must be certified by both);
        mean, std and UCB are the main model's. While :attr:`relaxed`, the LCB uses ``backup_beta``. With the
        ``lipschitz`` option the LCB is LoSBO's bound on the data instead (opt.lipschitz).
        """
        return self._bounds_parts(Xc)[:4]

    def _bounds_parts(self, Xc: np.ndarray) -> tuple[np.ndarray, ...]:
        """:meth:`bounds` and the per-model capped means and stds it took the LCB from (two (k, m) arrays)."""
        mu, sd = self.model.predict(Xc)
        if self.config.y_max is not None:
            mu = np.minimum(mu, self.config.y_max)
        b_ucb = self.config.beta if self.config.beta_ucb is None else self.config.beta_ucb
        beta = self.adaptive.backup_beta if self.relaxed else self.beta
        mu_c, sd_c = self._capped(Xc, (mu, sd))
        if self.config.lipschitz is not None and not self.relaxed:
            lcb = lipschitz.lower_bound(self, Xc)  # LoSBO: the data's Lipschitz bound certifies, not the GP
        else:
            lcb = np.min(mu_c - beta * sd_c, axis=0)
        if self.acq_model is not None:
            mu_a, sd_a = self.acq_model.predict(Xc)
            if self.config.y_max is not None:
                mu_a = np.minimum(mu_a, self.config.y_max)
            return mu, sd, lcb, mu_a + b_ucb * sd_a, mu_c, sd_c
        return mu, sd, lcb, mu + b_ucb * sd, mu_c, sd_c

    def safe_mask(self, Xc: np.ndarray) -> np.ndarray:
        """(m,) bool: which of Xc may be queried (LCB ≥ p_min, outside every exclusion ball, ...)."""
        return self.feasible(Xc, self.bounds(Xc)[2])

    def feasible(self, Z: np.ndarray, lcb: np.ndarray) -> np.ndarray:
        """(m,) bool: Z (m, d) with lower bounds ``lcb`` (m,) certified (LCB ≥ p_min, no unsafe or failed trial
        nearby, not below the symptom rule's floor: opt.symptom_rule); with a trust region also inside it, and — once
        trials have aborted, or while :attr:`relaxed` — predicted by the failure model to abort and crash rarely
        enough (censored aborts steer the search)."""
        ok = lcb >= self.p_min
        floor = symptom_rule.symptom_floor(self)
        if floor is not None:
            ok &= Z[:, self.config.chatter_dim] >= floor
        if ok.any():
            ok[ok] = ~region.excluded(self, Z[ok])
        if self.tr is not None and ok.any():
            ok &= self.tr.contains(Z)
        if self.failures is not None and (self.relaxed or not self.complete.all()) and ok.any():
            ok[ok] = self.failures.acceptable(Z[ok], self.adaptive.abort_tol, self.adaptive.crash_tol)
        return ok

    # -- the step -----------------------------------------------------------------------------------------------
    def propose(self) -> Proposal:
        """Next query point (certified safe unless ``kind`` is "fallback" or ends in "/backup")."""
        a = self.adaptive
        exploring = phases.exploring(self)
        budget_left = a.max_aborts is None or self.aborts < a.max_aborts
        # The backup is trusted only until it fails once: after a crash (the backup did not recover) the plant's
        # failures are known to be too fast for it, and only certified points are flown.
        trusted = not self.crashed[self.n_prior :].any()
        self.relaxed = a.backup_beta is not None and exploring and budget_left and trusted
        try:
            return self._propose()
        finally:
            self.relaxed = False

    def _propose(self) -> Proposal:
        c = self.config
        if lines.line_turn(self):
            line = lines.coordinate_proposal(self)
            if line is not None:
                return line
        if symptom_rule.symptom_turn(self):
            line = symptom_rule.symptom_proposal(self)
            if line is not None:
                return line
        mu_d, sd_d, lcb_d, ucb_d = self.bounds(self.X)
        C = region.candidates(self, region.anchors(self, lcb_d, ucb_d))  # opt.region: clouds around anchors
        _, _, lcb, _ = self.bounds(C)
        if not self.feasible(C, lcb).any():
            self.fallbacks += 1
            i = region.fallback_index(self, lcb_d)
            return Proposal(self.X[i].copy(), "fallback", float(mu_d[i]), float(sd_d[i]), float(lcb_d[i]))
        rule = phases.choose_rule(self, C, lcb_d)
        score, ok = rule(C)
        pool = rule.pool(C) if isinstance(rule, BoundaryExpansion) else ok
        score = np.where(pool, score, -np.inf)
        order = np.argsort(-score)[: c.refine_starts]
        order = order[np.isfinite(score[order])]
        starts, s_ref = refine(rule, C[order], self.rng, c.refine_rounds, c.refine_samples, c.refine_scale,
                               free=self.free)
        x = starts[int(np.argmax(s_ref))]
        parts = self._bounds_parts(x[None, :])
        if not self.feasible(x[None, :], parts[2])[0]:  # cannot happen (refine only accepts feasible moves): a guard
            x = C[order[0]]
            parts = self._bounds_parts(x[None, :])
        return self.finish_proposal(x, rule.kind, parts)

    def finish_proposal(self, x: np.ndarray, kind: str, parts: tuple[np.ndarray, ...] | None = None) -> Proposal:
        """The query x (d,) as a :class:`Proposal`: its posterior summary (``parts``: :meth:`_bounds_parts` at x if
        already computed), noted for the β calibration, with "/backup" added to ``kind`` while :attr:`relaxed`
        if only the backup's β certifies it."""
        m, s, lo, _, mu_c, sd_c = self._bounds_parts(x[None, :]) if parts is None else parts
        self.calibration.predicted(x, mu_c[:, 0], sd_c[:, 0])
        if self.relaxed:
            self.relaxed = False
            if not self.safe_mask(x[None, :])[0]:
                kind += "/backup"
        return Proposal(x.copy(), kind, float(m[0]), float(s[0]), float(lo[0]))

    # -- recommendation (opt.recommend) ---------------------------------------------------------------------------
    def smoothed(self) -> tuple[np.ndarray, np.ndarray]:
        """(n,) recommendation criterion at the data: smoothed posterior mean and LCB (opt.recommend.smoothed)."""
        return recommend.smoothed(self)

    def recommend(self) -> tuple[int, float, float]:
        """Data index of the recommended point with its mean and LCB (opt.recommend.model_choice)."""
        return recommend.model_choice(self)
