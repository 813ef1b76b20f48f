"""Where the safe optimiser looks: the anchors its candidate clouds are centred on, the connected search region,
the candidate set, the incumbent (the trust region's centre) and the fallback when nothing is certified."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ksbo_mav.opt.acquisition.candidates import local_gaussian, sobol
from ksbo_mav.opt.acquisition.certificate import Certificate
from ksbo_mav.opt.acquisition.growing_box import GrowingBox
from ksbo_mav.opt.models.safety_model import SafetyModel
from ksbo_mav.opt.observations import Observations

#: Prior points this close (unit cube) to one of the optimiser's evaluations join its search region ("x0" mode).
CONNECT_RADIUS = 0.1


@dataclass
class SearchRegion:
    """Candidate generation in the subspace ``free`` (d,) bool through ``x0`` (d,): ``n_local`` Gaussian points
    at ``local_scales`` around up to ``n_anchors`` anchors, plus ``n_global`` Sobol points when ``explore_from``
    is "all" ("x0": the region grows from the start; no global points). Local points stay in the growing search
    ``box`` where there is one (opt.acquisition.growing_box), else in the unit cube."""

    free: np.ndarray
    x0: np.ndarray
    n_anchors: int = 32
    n_local: int = 1536
    local_scales: tuple[float, ...] = (0.02, 0.05, 0.1, 0.2)
    n_global: int = 256
    explore_from: str = "x0"
    box: GrowingBox | None = None

    def anchors(self, obs: Observations, lcb_d: np.ndarray, ucb_d: np.ndarray, rng: np.random.Generator,
                center: np.ndarray | None = None) -> np.ndarray:
        """(k, d) certified (``lcb_d`` (n,) at the data), completed, connected observations, best by UCB
        (``ucb_d`` (n,)) then random; the trust region's ``center`` (d,) first when given."""
        ok = (lcb_d >= obs.p_min) & (obs.y >= obs.p_min) & obs.complete
        ok &= self.connected(obs)
        idx = np.flatnonzero(ok)
        if idx.size == 0:
            return obs.X[[int(np.argmax(np.where(obs.complete, lcb_d, -np.inf)))]]
        n = self.n_anchors
        best = idx[np.argsort(-ucb_d[idx])][: max(n // 2, 1)]
        rest = np.setdiff1d(idx, best)
        if rest.size:
            best = np.concatenate([best, rng.choice(rest, size=min(n - best.size, rest.size), replace=False)])
        A = obs.X[best]
        return A if center is None else np.vstack([center, A])

    def connected(self, obs: Observations) -> np.ndarray:
        """(n,) bool: observations that may anchor candidate clouds.

        All of them under ``explore_from="all"``; under ``"x0"`` the optimiser's own evaluations (the start
        first) and the prior points linked to them by a chain of steps of at most ``CONNECT_RADIUS``, so the
        search region grows from the start and takes in prior points once it reaches them. (A resumed campaign
        passes its earlier trials as prior: their chain from the start keeps them connected.)
        """
        n, m = obs.n, obs.n_prior
        if self.explore_from == "all" or m == 0:
            return np.ones(n, dtype=bool)
        linked = np.arange(n) >= m
        P = obs.X[:m]
        while True:
            d2 = ((P[:, None, :] - obs.X[linked][None, :, :]) ** 2).sum(-1).min(axis=1)
            new = (d2 <= CONNECT_RADIUS**2) & ~linked[:m]
            if not new.any():
                return linked
            linked[:m] |= new

    @property
    def lo(self) -> np.ndarray | float:
        """Lower edges the candidates stay within: the growing box's, else the cube's."""
        return 0.0 if self.box is None else self.box.lo

    @property
    def hi(self) -> np.ndarray | float:
        """Upper edges the candidates stay within: the growing box's, else the cube's."""
        return 1.0 if self.box is None else self.box.hi

    def candidates(self, anchors: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """(m, d) candidate set: local clouds around ``anchors`` (k, d) plus global Sobol (moved dims only)."""
        local = local_gaussian(anchors, self.n_local, self.local_scales, rng, free=self.free, lo=self.lo, hi=self.hi)
        glob = sobol(self.n_global if self.explore_from == "all" else 0, self.x0.size, rng)
        C = np.vstack([local, glob])
        # Dimensions outside the search space stay at the start value (they are not in the kernel, so the model
        # could not tell a change there from no change).
        C[:, ~self.free] = self.x0[~self.free]
        return C

    def incumbent(self, obs: Observations, model: SafetyModel, cert: Certificate, flown: bool = False) -> np.ndarray:
        """(d,) best completed safe trial by ``model``'s posterior mean (the trust region's centre; x0 before any),
        outside the failures' grown exclusion balls: a centre inside a ball larger than the trust region leaves no
        candidate, and the run would fall back to re-flying one point for the rest of its budget. ``flown``: among
        this run's evaluations only (the prior's points never moved the vehicle: a growing box follows flights)."""
        ok = obs.safe_complete()
        if flown:
            ok &= np.arange(obs.n) >= obs.n_prior
        if ok.any() and obs.any_failed:
            ok[ok] = ~cert.exclusion.in_grown_ball(obs, obs.X[ok])
        if not ok.any():
            return self.x0.copy()
        mu, _ = model.predict(obs.X[ok])
        return obs.X[ok][int(np.argmax(mu))].copy()

    def fallback_index(self, obs: Observations, lcb_d: np.ndarray, cert: Certificate) -> int:
        """Data index re-flown when no candidate is certified: the best-LCB completed observation (lcb_d (n,)) in
        the search subspace (x0 always is one), never one the failure model now expects to abort or crash, nor
        (with growing balls) one inside a failed trial's ball — the same gains may complete once and fail next."""
        inside = np.all(obs.X[:, ~self.free] == self.x0[~self.free], axis=1) & obs.complete
        if cert.failures is not None and obs.any_failed and inside.any():
            # A trial that completed once may abort the next time (bistable gains on a random start); x0 stays.
            ok = cert.acceptable(obs, obs.X) & ~cert.exclusion.in_grown_ball(obs, obs.X)
            inside &= ok | obs.at(self.x0)
        return int(np.argmax(np.where(inside, lcb_d, -np.inf))) if inside.any() else int(np.argmax(lcb_d))
