"""Safe Bayesian optimisation in the unit cube: safe set from the GP's lower bound, local candidates, two rules.

Safe set S_n = {x : LCB_n(x) = μ_n(x) − β σ_n(x) ≥ p_min}, with σ the *marginal* posterior std (a joint
posterior over thousands of candidates is never formed; SafeCtrlBO's pitfall 2). Candidates are Gaussian clouds
around certified-safe observations plus a global Sobol set, refined by a constrained local search, so the safe
region is reachable in 9-D (pitfall 4). Two acquisition rules:

* ``"ucb"`` — SafeCtrlBO's rule with its bug fixed: for the first ``expansion_iters`` *BO iterations* (not total
  observations, pitfall 3) the most uncertain safe candidate near the safety boundary is evaluated, afterwards the
  safe UCB maximiser.
* ``"safeopt"`` — SafeOpt's rule: the widest confidence interval among the plausible maximisers
  M = {x ∈ S : UCB(x) ≥ max_S LCB} and the boundary points (SafeOptSwarm-style stand-in for SafeOpt's expanders,
  which would need one GP update per expander candidate).

If no candidate is certified safe the observation with the largest LCB is re-evaluated (a *fallback*); with a
known-safe start this is always a point that was safe before.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ksbo_mav.opt.candidates import local_gaussian, refine, sobol
from ksbo_mav.opt.model import SafetyModel
from ksbo_mav.opt.problem import Problem

RULES = ("ucb", "safeopt")
#: Prior points this close (unit cube) to one of the optimiser's evaluations join its search region ("x0" mode).
CONNECT_RADIUS = 0.1
#: The final exploitation phase takes at most 1/EXPLOIT_SHARE of the budget.
EXPLOIT_SHARE = 5


@dataclass(frozen=True)
class SafeBOConfig:
    """Settings of :class:`SafeBO` (building-block defaults; the user-facing defaults, tuned on the planar
    quadrotor, are those of :class:`ksbo_mav.opt.options.Options`).

    Attributes:
        beta: safety multiplier: certified safe ⇔ μ − beta σ ≥ p_min.
        beta_ucb: exploration multiplier of the UCB acquisition; None = ``beta``.
        rule: ``"ucb"`` or ``"safeopt"`` (module docstring).
        expansion_iters: BO iterations of boundary exploration under the ``"ucb"`` rule.
        boundary_tol: boundary band ``LCB − p_min ≤ boundary_tol × signal_std``.
        n_global: global Sobol candidates per iteration.
        n_local: local Gaussian candidates per iteration.
        local_scales: standard deviations (unit cube) of the local clouds.
        n_anchors: certified-safe observations the clouds are centred on (best by UCB, then random).
        refine_starts, refine_rounds, refine_samples, refine_scale: constrained local refinement (candidates.refine).
        refit_every: full refit (ML-II if the model spec asks) every this many iterations; 0 = rank-one updates only.
        recommend: ``"mean"`` or ``"lcb"``: criterion for the recommendation among evaluated certified-safe points.
        cap_mean: in the safety bound use ``min(μ, max observed y)``: a GP mean overshooting every observation is
            extrapolation, and certifying a point on it was the commonest route to unsafe queries on the quadrotor.
        recommend_noise: if set, the recommendation uses a second GP (same kernel) with noise std
            ``recommend_noise × signal_std``: one lucky
            episode of a bistable gain vector next to crashed neighbours is then averaged with them.
        y_max: known upper bound of the objective (P ≤ 1 on the quadrotor task); posterior means above it are
            clipped in both bounds, so an overshooting additive model cannot drive the acquisition there.
        exclusion_radius: candidates closer than this (unit cube, Euclidean) to an unsafe observation are never
            certified. A Gaussian-noise GP treats one lucky episode of a bistable gain vector (0.9, where most
            initial conditions crash) as solid evidence and keeps certifying the shell around it, crash after crash;
            an unsafe outcome nearby is stronger evidence against the region than the GP admits.
        exploit_beta: the exploitation phase maximises ``μ − exploit_beta·σ`` (0: the posterior mean); a positive
            value keeps it nearer the data (on the quadrotor μ − σ cost 0.01 of re-flown E[P] and no tuning seed
            needed it for safety, so the default is 0).
        explore_from: ``"all"``: candidate clouds grow around any certified observation, plus global Sobol points;
            ``"x0"``: only around the start and the optimiser's own evaluations (the prior informs the GP but does
            not seed candidates), no global points. Under a safety bound β the certified boundary of a region with
            mean μ has σ ≤ μ/β, so UCB there is at most μ(1 + β_ucb/β): a flat prior plateau at P 0.4 outbids a
            steep slope starting at P 0.2 for the whole budget.
        exploit_last: the last this many evaluations (at most a fifth of ``SafeBO.budget`` when that is set) maximise
            the posterior mean inside the safe set (no exploration bonus): exploring then cannot pay off any more,
            it only risks unsafe queries.
    """

    beta: float = 2.0
    beta_ucb: float | None = None
    rule: str = "ucb"
    expansion_iters: int = 10
    boundary_tol: float = 0.1
    n_global: int = 256
    n_local: int = 1536
    local_scales: tuple[float, ...] = (0.02, 0.05, 0.1, 0.2)
    n_anchors: int = 32
    refine_starts: int = 8
    refine_rounds: int = 4
    refine_samples: int = 32
    refine_scale: float = 0.05
    refit_every: int = 0
    recommend: str = "mean"
    cap_mean: bool = True
    recommend_noise: float | None = None
    y_max: float | None = None
    exploit_last: int = 0
    exclusion_radius: float = 0.0
    explore_from: str = "all"
    exploit_beta: float = 0.0


@dataclass
class Proposal:
    """One proposed query: x (d,) unit cube, its posterior summary and how it was chosen."""

    x: np.ndarray
    kind: str  # "expand" | "ucb" | "safeopt" | "exploit" | "fallback"
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
    X: np.ndarray = field(init=False)
    y: np.ndarray = field(init=False)
    iteration: int = field(default=0, init=False)
    fallbacks: int = field(default=0, init=False)
    remaining: int | None = field(default=None, init=False)  # evaluations left, set by the driver loop

    def __post_init__(self) -> None:
        if self.config.rule not in RULES:
            raise ValueError(f"unknown rule {self.config.rule!r}; expected one of {RULES}")
        self.X = np.zeros((0, self.model.dim))
        self.y = np.zeros(0)

    # -- data ---------------------------------------------------------------------------------------------------
    def fit(self, X: np.ndarray, y: np.ndarray) -> None:
        """Fit on all data so far: X (n, d) unit cube, y (n,)."""
        self.X = np.asarray(X, dtype=float).reshape(-1, self.model.dim)
        self.y = np.asarray(y, dtype=float).reshape(-1)
        if self.x0 is None:
            self.x0 = self.X[0].copy()
        self.model.fit(self.X, self.y)
        if self.safety_model is not None:
            self.safety_model.fit(self.X, self.y)

    def observe(self, x: np.ndarray, y: float) -> None:
        """Add one evaluation and advance the BO iteration counter (which keys the expansion phase)."""
        self.iteration += 1
        self.X = np.vstack([self.X, np.asarray(x, float).reshape(1, -1)])
        self.y = np.append(self.y, float(y))
        k = self.config.refit_every
        for m in (self.model, self.safety_model):
            if m is None:
                continue
            if k and self.iteration % k == 0:
                m.fit(self.X, self.y)
            else:
                m.add(x, y)

    # -- posterior ----------------------------------------------------------------------------------------------
    @property
    def p_min(self) -> float:
        return self.model.p_min

    def bounds(self, Xc: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Posterior mean, marginal std, LCB (safety β) and UCB (acquisition β) at Xc (m, d); four (m,) arrays.

        With a ``safety_model`` the LCB is the smaller of both models' bounds (a point must be certified by both);
        mean, std and UCB are the main model's.
        """
        mu, sd = self.model.predict(Xc)
        if self.config.y_max is not None:
            mu = np.minimum(mu, self.config.y_max)
        b_ucb = self.config.beta if self.config.beta_ucb is None else self.config.beta_ucb
        cap = self.y.max() if self.config.cap_mean and self.y.size else np.inf
        if self.config.y_max is not None:
            cap = min(cap, self.config.y_max)
        lcb = np.minimum(mu, cap) - self.config.beta * sd
        if self.safety_model is not None:
            mu_s, sd_s = self.safety_model.predict(Xc)
            lcb = np.minimum(lcb, np.minimum(mu_s, cap) - self.config.beta * sd_s)
        return mu, sd, lcb, mu + b_ucb * sd

    def safe_mask(self, Xc: np.ndarray) -> np.ndarray:
        """(m,) bool: which of Xc are certified safe (LCB ≥ p_min and outside every exclusion ball)."""
        return self.feasible(Xc, self.bounds(Xc)[2])

    def feasible(self, Z: np.ndarray, lcb: np.ndarray) -> np.ndarray:
        """(m,) bool: Z (m, d) with lower bounds ``lcb`` (m,) certified (LCB ≥ p_min, no unsafe point nearby)."""
        ok = lcb >= self.p_min
        r = self.config.exclusion_radius
        bad = self.X[self.y < self.p_min]
        if r > 0 and bad.shape[0] and ok.any():
            d2 = ((Z[ok, None, :] - bad[None, :, :]) ** 2).sum(-1).min(axis=1)
            idx = np.flatnonzero(ok)
            ok[idx[d2 < r * r]] = False
        return ok

    # -- candidates ---------------------------------------------------------------------------------------------
    def _anchors(self, lcb_d: np.ndarray, ucb_d: np.ndarray) -> np.ndarray:
        ok = (lcb_d >= self.p_min) & (self.y >= self.p_min)
        ok &= self._connected()
        idx = np.flatnonzero(ok)
        if idx.size == 0:
            return self.X[[int(np.argmax(lcb_d))]]
        n = self.config.n_anchors
        best = idx[np.argsort(-ucb_d[idx])][: max(n // 2, 1)]
        rest = np.setdiff1d(idx, best)
        if rest.size:
            best = np.concatenate([best, self.rng.choice(rest, size=min(n - best.size, rest.size), replace=False)])
        return self.X[best]

    def _connected(self) -> np.ndarray:
        """(n,) bool: observations that may anchor candidate clouds.

        All of them under ``explore_from="all"``; under ``"x0"`` the optimiser's own evaluations (the start
        first) and the prior points linked to them by a chain of steps of at most ``CONNECT_RADIUS``, so the
        search region grows from the start and takes in prior points once it reaches them. (A resumed campaign
        passes its earlier trials as prior: their chain from the start keeps them connected.)
        """
        n = self.y.size
        if self.config.explore_from == "all" or self.n_prior == 0:
            return np.ones(n, dtype=bool)
        linked = np.arange(n) >= self.n_prior
        P = self.X[: self.n_prior]
        while True:
            d2 = ((P[:, None, :] - self.X[linked][None, :, :]) ** 2).sum(-1).min(axis=1)
            new = (d2 <= CONNECT_RADIUS**2) & ~linked[: self.n_prior]
            if not new.any():
                return linked
            linked[: self.n_prior] |= new

    def candidates(self, anchors: np.ndarray) -> np.ndarray:
        """(m, d) candidate set: local clouds around ``anchors`` (k, d) plus global Sobol (moved dims only)."""
        c = self.config
        local = local_gaussian(anchors, c.n_local, c.local_scales, self.rng, free=self.free)
        glob = sobol(c.n_global if c.explore_from == "all" else 0, self.model.dim, self.rng)
        C = np.vstack([local, glob])
        # Dimensions outside the search space stay at the start value (they are not in the kernel, so the model
        # could not tell a change there from no change).
        C[:, ~self.free] = self.x0[~self.free]
        return C

    def _widest_safe(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Refinement score of the pure-exploration rules: posterior std (m,) and certified mask (m,) of Z (m, d)."""
        _, s, lo, _ = self.bounds(Z)
        return s, self.feasible(Z, lo)

    # -- the step -----------------------------------------------------------------------------------------------
    def propose(self) -> Proposal:
        """Next query point (certified safe unless ``kind == "fallback"``)."""
        c = self.config
        mu_d, sd_d, lcb_d, ucb_d = self.bounds(self.X)
        C = self.candidates(self._anchors(lcb_d, ucb_d))
        mu, sd, lcb, ucb = self.bounds(C)
        safe = self.feasible(C, lcb)
        if not safe.any():
            self.fallbacks += 1
            # Re-evaluate the best-LCB observation that lies in the search subspace (x0 always does).
            inside = np.all(self.X[:, ~self.free] == self.x0[~self.free], axis=1)
            i = int(np.argmax(np.where(inside, lcb_d, -np.inf))) if inside.any() else int(np.argmax(lcb_d))
            return Proposal(self.X[i].copy(), "fallback", float(mu_d[i]), float(sd_d[i]), float(lcb_d[i]))
        band = c.boundary_tol * self.model.signal_std
        p_min = self.p_min

        n_exploit = min(c.exploit_last, self.budget // EXPLOIT_SHARE) if self.budget > 0 else c.exploit_last
        if self.remaining is not None and self.remaining <= n_exploit:
            kind = "exploit"
            kb = c.exploit_beta

            def evaluate(Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
                m, s, lo, _ = self.bounds(Z)
                return m - kb * s, self.feasible(Z, lo)

            score = np.where(safe, mu - kb * sd, -np.inf)
        elif c.rule == "ucb" and self.iteration >= c.expansion_iters:
            kind = "ucb"

            def evaluate(Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
                _, _, lo, up = self.bounds(Z)
                return up, self.feasible(Z, lo)

            score = np.where(safe, ucb, -np.inf)
        elif c.rule == "ucb":
            kind = "expand"
            boundary = safe & (lcb - p_min <= band)
            pool = boundary if boundary.any() else safe
            evaluate = self._widest_safe
            score = np.where(pool, sd, -np.inf)
        else:
            kind = "safeopt"
            best_lcb = max(float(lcb[safe].max()), float(np.max(np.where(lcb_d >= p_min, lcb_d, -np.inf))))

            def in_pool(Z: np.ndarray, lo: np.ndarray, up: np.ndarray) -> np.ndarray:
                return self.feasible(Z, lo) & ((up >= best_lcb) | (lo - p_min <= band))

            def in_pool_widest(Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
                _, s, lo, up = self.bounds(Z)
                return s, in_pool(Z, lo, up)

            pool, evaluate = in_pool(C, lcb, ucb), in_pool_widest
            if not pool.any():  # an observation's LCB beats every candidate's UCB: widest safe candidate
                pool, evaluate = safe, self._widest_safe

            score = np.where(pool, sd, -np.inf)

        order = np.argsort(-score)[: c.refine_starts]
        order = order[np.isfinite(score[order])]
        starts, s_ref = refine(
            evaluate, C[order], self.rng, c.refine_rounds, c.refine_samples, c.refine_scale, free=self.free
        )
        j = int(np.argmax(s_ref))
        x = starts[j]
        m, s, lo, _ = self.bounds(x[None, :])
        if not self.feasible(x[None, :], lo)[0]:  # cannot happen (refine only accepts feasible moves): a guard
            x = C[order[0]]
            m, s, lo, _ = self.bounds(x[None, :])
        return Proposal(x.copy(), kind, float(m[0]), float(s[0]), float(lo[0]))

    # -- recommendation -----------------------------------------------------------------------------------------
    def recommend(self) -> tuple[int, float, float]:
        """Index into the data of the recommended point, with its posterior mean and LCB.

        Among observations that were safe *and* are certified safe by the model, the best posterior mean (or LCB):
        the model's smoothed judgement, not the luckiest noisy observation (part D: bistable gains).
        """
        mu, _, lcb, _ = self.bounds(self.X)
        ok = (self.y >= self.p_min) & (lcb >= self.p_min)
        if self.config.recommend_noise is not None:
            smooth = SafetyModel(self.model.spec.with_(signal_std=self.model.signal_std,
                                                       noise_std=self.config.recommend_noise * self.model.signal_std),
                                 self.model.dim, self.p_min, self.model.seed)
            smooth.fit(self.X, self.y)
            mu_s, sd_s = smooth.predict(self.X)
            mu, lcb = mu_s, mu_s - self.config.beta * sd_s
        if not ok.any():
            ok = self.y >= self.p_min
        if not ok.any():
            ok = np.ones_like(ok)
        crit = lcb if self.config.recommend == "lcb" else mu
        i = int(np.argmax(np.where(ok, crit, -np.inf)))
        return i, float(mu[i]), float(lcb[i])


def run_safe_bo(problem: Problem, bo: SafeBO, max_iters: int | None = None) -> list[dict]:
    """Spend the remaining budget of ``problem`` with ``bo`` (already fitted on ``problem.data()``).

    With ``max_iters`` stop once ``bo.iteration`` reaches it (e.g. to re-select the kernel).

    Returns one record per query (kind, posterior mean/std/LCB at proposal time, observed y): the data for
    checking the model's calibration (how often was a certified point unsafe?).
    """
    log = []
    while problem.remaining > 0 and (max_iters is None or bo.iteration < max_iters):
        bo.remaining = problem.remaining
        p = bo.propose()
        y = problem.evaluate(p.x)
        bo.observe(p.x, y)
        log.append({"kind": p.kind, "mu": p.mu, "sd": p.sd, "lcb": p.lcb, "y": y})
    return log
