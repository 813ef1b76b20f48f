"""Safe Bayesian optimisation in the unit cube: a short loop over small parts, each owning its own state.

* :class:`~ksbo_mav.opt.observations.Observations` — the trials (points, scores, outcomes).
* :class:`~ksbo_mav.opt.models.surrogate.Surrogate` — the additive GP of the selected orders, the local SE-ARD
  safety GP and the learned safety scale (opt.models.scale).
* :class:`~ksbo_mav.opt.acquisition.certificate.Certificate` — which points may be queried: LCB = μ − β σ ≥ p_min
  with σ the *marginal* posterior std (a joint posterior over thousands of candidates is never formed), the
  exclusion balls, the trust region and the failure model.
* :class:`~ksbo_mav.opt.acquisition.region.SearchRegion` — candidates: Gaussian clouds around certified
  observations (plus a global Sobol set), refined by a constrained local search, so the safe region is reachable
  in 9-D.
* :class:`~ksbo_mav.opt.methods.phases.Phases` — the proposers: boundary expansion, safe UCB (or SafeOpt's rule),
  then exploitation; the :class:`~ksbo_mav.opt.acquisition.trust_region.TrustRegion` keeps them near the
  incumbent; a :class:`~ksbo_mav.opt.acquisition.growing_box.GrowingBox`, where the caller gives limits, moves the
  search box's edges out when the incumbent reaches them.
* :class:`~ksbo_mav.opt.methods.recommend.Recommender` and :class:`~ksbo_mav.opt.methods.refly.ReflyPhase` — the
  recommendation.

If no candidate is certified the best-LCB observation is re-flown (a *fallback*); with a known-safe start this
is always a point that was safe before. Aborted and crashed trials are censored when ``Observations.censor``:
they enter the failure model and the exclusion balls, never the GPs as values. Build one with
:func:`ksbo_mav.opt.methods.build.build_safe_bo`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ksbo_mav.opt.acquisition.candidates import refine
from ksbo_mav.opt.acquisition.certificate import Certificate
from ksbo_mav.opt.acquisition.growing_box import Growth, GrowingBox
from ksbo_mav.opt.acquisition.region import SearchRegion
from ksbo_mav.opt.acquisition.rules import BoundaryExpansion
from ksbo_mav.opt.acquisition.trust_region import TrustRegion
from ksbo_mav.opt.methods.phases import Phases
from ksbo_mav.opt.methods.recommend import Recommender
from ksbo_mav.opt.methods.refly import ReflyPhase
from ksbo_mav.opt.methods.stopping import StoppingRule
from ksbo_mav.opt.models.safety_model import SafetyModel
from ksbo_mav.opt.models.surrogate import Surrogate
from ksbo_mav.opt.observations import Observations
from ksbo_mav.opt.evaluation import Outcome


@dataclass
class Proposal:
    """One proposed query: x (d,) unit cube, its posterior summary and how it was chosen: "expand", "ucb",
    "safeopt", "exploit", "fallback", "refly" or "stress" (+ "/backup" if only the backup's β certifies it)."""

    x: np.ndarray
    kind: str
    mu: float
    sd: float
    lcb: float


@dataclass(frozen=True)
class Refinement:
    """Constrained local refinement of the best ``starts`` candidates (opt.acquisition.candidates.refine)."""

    starts: int = 8
    rounds: int = 4
    samples: int = 32
    scale: float = 0.05


@dataclass
class SafeBO:
    """Safe BO state machine: ``propose`` → evaluate → ``observe``; the caller owns the evaluations."""

    obs: Observations
    surrogate: Surrogate
    certificate: Certificate
    region: SearchRegion
    phases: Phases
    recommender: Recommender
    refly: ReflyPhase
    rng: np.random.Generator
    trust_region: TrustRegion | None = None
    on_grow: Callable[[Growth], None] | None = None  # hears each edge the box moves
    refinement: Refinement = field(default_factory=Refinement)
    refit_every: int = 0  # full refit every this many iterations; 0 = rank-one updates
    max_aborts: int | None = None  # the backup may cover trials only while fewer trials failed
    stopping: StoppingRule | None = None  # ends the search once the next proposal cannot pay (opt.methods.stopping)
    iteration: int = field(default=0, init=False)
    fallbacks: int = field(default=0, init=False)
    remaining: int | None = field(default=None, init=False)  # evaluations left for the search (the driver sets it)

    @property
    def box(self) -> GrowingBox | None:
        """The growing search box (the candidates' region holds it); None: the search box is the unit cube."""
        return self.region.box

    @property
    def model(self) -> SafetyModel:
        return self.surrogate.model

    @property
    def p_min(self) -> float:
        return self.obs.p_min

    # -- data ---------------------------------------------------------------------------------------------------
    def fit(self, X: np.ndarray, y: np.ndarray, complete: np.ndarray | None = None,
            crashed: np.ndarray | None = None) -> None:
        """Fit on all data so far: X (n, d) unit cube, y (n,), optional (n,) bool outcome masks."""
        self.obs.reset(X, y, complete, crashed)
        if self.region.x0 is None:
            self.region.x0 = self.obs.X[0].copy()
        target = self.surrogate.scale_target
        if target is not None:
            self.surrogate.scale.start(target)
        self._refit(learn=self.surrogate.scale.learn)
        if self.trust_region is not None:
            self.trust_region.center = self._incumbent()

    def _refit(self, learn: bool = False) -> None:
        self.surrogate.fit(self.obs, learn, self.rng)
        target = self.surrogate.scale_target
        if self.trust_region is not None and target is not None and np.ndim(target.spec.lengthscale):
            self.trust_region.set_weights(np.asarray(target.spec.lengthscale, dtype=float))
        self.certificate.fit_failures(self.obs, self.surrogate.safety_lengthscales())

    def _incumbent(self) -> np.ndarray:
        return self.region.incumbent(self.obs, self.model, self.certificate)

    def observe(self, x: np.ndarray, y: float, outcome: Outcome = Outcome.COMPLETE) -> None:
        """Add one trial and advance the BO iteration counter (which keys the expansion phase).

        A completed trial updates the GPs (rank-one, or a full refit every ``refit_every`` iterations or when the
        safety scale is relearnt); an aborted or crashed one the failure records. A failure at new gains that the
        safety GP had certified shrinks the safety scale (re-flights of flown gains say nothing about it).
        """
        self.iteration += 1
        obs, sur = self.obs, self.surrogate
        done = outcome is Outcome.COMPLETE
        unsafe = y < obs.p_min and sur.scale_target is not None
        shrunk = sur.scale.shrink(done, unsafe, novel=not bool(obs.at(x).any()))
        obs.add(x, y, outcome)
        learn = sur.scale.learn_now(self.iteration, obs.n)
        k = self.refit_every
        failure_news = not done and (self.certificate.failures is not None or sur.scale.failure_shrink < 1.0)
        if learn or shrunk or (k and self.iteration % k == 0) or failure_news:
            self._refit(learn=learn)
        else:
            if done or not obs.censor:
                sur.add(x, y)
            # Every trial joins the failure records at once: a success next to a failure lowers its predicted
            # P(abort) for the very next proposal.
            if self.certificate.failures is not None:
                self.certificate.failures.fit(obs.X, ~obs.complete, obs.crashed)
        if self.trust_region is not None or self.box is not None:
            self._follow(outcome, done and y >= obs.p_min, x)

    def _follow(self, outcome: Outcome, safe: bool, x: np.ndarray) -> None:
        """The trust region and the growing box follow the incumbent after a trial at ``x``."""
        center = self._incumbent()
        if self.trust_region is not None:
            # A success is a trial that becomes the incumbent by the posterior mean, not one whose flown value beats
            # the best flown: after a lucky flight no trial within the noise would beat it, and the region would
            # never grow (an ArduCopter SITL campaign stalled at 72 % of a long one's cut that way).
            before = self.trust_region.center
            moved = before is None or not np.allclose(center, before)
            self.trust_region.update(outcome, safe and moved and np.allclose(center, x))
            self.trust_region.center = center
        if self.box is not None:  # moved by flights alone: the prior's points never flew
            flown = self.region.incumbent(self.obs, self.model, self.certificate, flown=True)
            for m in self.box.update(flown, self.iteration, self.region.free):
                if self.on_grow is not None:
                    self.on_grow(m)

    # -- posterior (the acquisition rules' view: opt.acquisition.rules.Posterior) --------------------------------------
    def bounds(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Posterior mean, marginal std, LCB and UCB at Z (m, d); four (m,) arrays (opt.acquisition.certificate)."""
        return self.certificate.parts(self.surrogate, self.obs, Z)[:4]

    def feasible(self, Z: np.ndarray, lcb: np.ndarray) -> np.ndarray:
        """(m,) bool: Z (m, d) with lower bounds ``lcb`` (m,) may be queried (opt.acquisition.certificate)."""
        return self.certificate.feasible(self.obs, Z, lcb, self.trust_region)

    def safe_mask(self, Z: np.ndarray) -> np.ndarray:
        """(m,) bool: which of Z (m, d) may be queried."""
        return self.feasible(Z, self.bounds(Z)[2])

    # -- the step -----------------------------------------------------------------------------------------------
    def propose(self) -> Proposal:
        """Next query point (certified safe unless ``kind`` is "fallback" or ends in "/backup").

        The backup may cover the trial (``backup_beta``) while exploring, within the abort budget, and only until
        it fails once: after a crash the plant's failures are known to be too fast for it."""
        obs, cert = self.obs, self.certificate
        budget_left = self.max_aborts is None or obs.aborts < self.max_aborts
        trusted = not obs.crashed[obs.n_prior :].any()
        cert.relaxed = (cert.backup_beta is not None and self.phases.exploring(self.remaining) and budget_left
                        and trusted)
        try:
            return self._propose()
        finally:
            cert.relaxed = False

    def _propose(self) -> Proposal:
        obs, r = self.obs, self.refinement
        mu_d, sd_d, lcb_d, ucb_d = self.bounds(obs.X)
        center = None if self.trust_region is None else self.trust_region.center
        C = self.region.candidates(self.region.anchors(obs, lcb_d, ucb_d, self.rng, center), self.rng)
        _, _, lcb, _ = self.bounds(C)
        if not self.feasible(C, lcb).any():
            self.fallbacks += 1
            i = self.region.fallback_index(obs, lcb_d, self.certificate)
            return Proposal(obs.X[i].copy(), "fallback", float(mu_d[i]), float(sd_d[i]), float(lcb_d[i]))
        best_data_lcb = float(np.max(np.where((lcb_d >= obs.p_min) & obs.complete, lcb_d, -np.inf)))
        rule = self.phases.choose(self, self.iteration, self.remaining, self.model.signal_std, obs.p_min, C,
                                  best_data_lcb)
        score, ok = rule(C)
        pool = rule.pool(C) if isinstance(rule, BoundaryExpansion) else ok
        score = np.where(pool, score, -np.inf)
        order = np.argsort(-score)[: r.starts]
        order = order[np.isfinite(score[order])]
        starts, s_ref = refine(rule, C[order], self.rng, r.rounds, r.samples, r.scale, free=self.region.free,
                               lo=self.region.lo, hi=self.region.hi)
        x = starts[int(np.argmax(s_ref))]
        parts = self.certificate.parts(self.surrogate, obs, x[None, :])
        if not self.feasible(x[None, :], parts[2])[0]:  # cannot happen (refine only accepts feasible moves): a guard
            x = C[order[0]]
            parts = self.certificate.parts(self.surrogate, obs, x[None, :])
        return self._finish(x, rule.kind, parts)

    def _finish(self, x: np.ndarray, kind: str, parts: tuple[np.ndarray, ...]) -> Proposal:
        """The query x (d,) as a :class:`Proposal`, "/backup" added to ``kind`` when only the backup's β
        certifies it."""
        m, s, lo = parts[0], parts[1], parts[2]
        if self.certificate.relaxed:
            self.certificate.relaxed = False
            if not self.safe_mask(x[None, :])[0]:
                kind += "/backup"
        return Proposal(x.copy(), kind, float(m[0]), float(s[0]), float(lo[0]))

    # -- recommendation -----------------------------------------------------------------------------------------
    def smoothed(self) -> tuple[np.ndarray, np.ndarray]:
        """(n,) smoothed posterior mean and LCB at the data (opt.methods.recommend)."""
        return self.recommender.smoothed(self, self.model, self.obs)

    def criterion(self) -> np.ndarray:
        """(n,) the recommendation's criterion at the data."""
        return self.recommender.pick(*self.smoothed())

    def recommend(self) -> tuple[int, float, float]:
        """Data index of the model's recommended point with its smoothed mean and LCB (opt.methods.recommend)."""
        return self.recommender.model_choice(self, self.model, self.obs, self.certificate)

    def final_choice(self) -> tuple[int, float, float]:
        """The recommendation after the re-fly phase (opt.methods.refly), with its smoothed mean and LCB."""
        self.certificate.update_failures(self.obs)
        i = -1 if self.refly.eligible(self.obs) else self.recommend()[0]
        j = self.refly.final_choice(i, self.criterion, self.obs, self.certificate)
        m, lcb = self.smoothed()
        return j, float(m[j]), float(lcb[j])
