"""The safety certificate: which points the optimiser may query.

A point z is certified when every safety GP's lower bound clears the threshold, ``min_k (μ_k(z) − β σ_k(z)) ≥
p_min`` (σ the *marginal* posterior std; the means capped at the best score seen, an overshooting mean being
extrapolation), it lies outside the exclusion balls of bad trials, inside the trust region when there is one, and
— once trials have aborted, or while the backup may cover the trial (:attr:`Certificate.relaxed`, certified with
``backup_beta``) — the failure model predicts it to abort and crash rarely enough.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ksbo_mav.opt.acquisition.exclusion import Exclusion
from ksbo_mav.opt.acquisition.trust_region import TrustRegion
from ksbo_mav.opt.models.failure_model import FailureModel
from ksbo_mav.opt.models.surrogate import Surrogate
from ksbo_mav.opt.observations import Observations


@dataclass
class Certificate:
    """LCB with ``beta`` (``backup_beta`` while :attr:`relaxed`), UCB with ``beta_ucb`` (None: ``beta``), the
    exclusion balls and the failure model (kept when ``track_failures``; P(abort) ≤ ``abort_tol``, P(crash) ≤
    ``crash_tol``)."""

    beta: float = 4.0
    beta_ucb: float | None = 2.0
    backup_beta: float | None = None
    cap_mean: bool = True
    y_max: float | None = None
    exclusion: Exclusion = field(default_factory=Exclusion)
    track_failures: bool = False
    abort_tol: float = 0.3
    crash_tol: float = 0.1
    failures: FailureModel | None = field(default=None, init=False)
    relaxed: bool = field(default=False, init=False)

    def parts(self, sur: Surrogate, obs: Observations, Z: np.ndarray) -> tuple[np.ndarray, ...]:
        """At Z (m, d): mean, std, LCB, UCB (four (m,) arrays) and each safety GP's capped mean and std (two (k, m)
        arrays, main GP first). Mean, std and UCB are the main GP's (the UCB the acquisition GP's if there is one);
        the LCB is the smallest over the safety GPs."""
        mu, sd = sur.model.predict(Z)
        if self.y_max is not None:
            mu = np.minimum(mu, self.y_max)
        b_ucb = self.beta if self.beta_ucb is None else self.beta_ucb
        beta = self.backup_beta if self.relaxed else self.beta
        mu_c, sd_c = self._capped(sur, obs, Z, (mu, sd))
        lcb = np.min(mu_c - beta * sd_c, axis=0)
        if sur.acq_model is not None:
            mu_a, sd_a = sur.acq_model.predict(Z)
            if self.y_max is not None:
                mu_a = np.minimum(mu_a, self.y_max)
            return mu, sd, lcb, mu_a + b_ucb * sd_a, mu_c, sd_c
        return mu, sd, lcb, mu + b_ucb * sd, mu_c, sd_c

    def _capped(self, sur: Surrogate, obs: Observations, Z: np.ndarray, main: tuple[np.ndarray, np.ndarray]
                ) -> tuple[np.ndarray, np.ndarray]:
        yc = obs.y[obs.gp_mask]
        cap = yc.max() if self.cap_mean and yc.size else np.inf
        if self.y_max is not None:
            cap = min(cap, self.y_max)
        pairs = [main]
        if sur.safety_model is not None:
            pairs.append(sur.safety_model.predict(Z))
        return np.array([np.minimum(mu, cap) for mu, _ in pairs]), np.array([sd for _, sd in pairs])

    def feasible(self, obs: Observations, Z: np.ndarray, lcb: np.ndarray, tr: TrustRegion | None = None
                 ) -> np.ndarray:
        """(m,) bool: Z (m, d) with lower bounds ``lcb`` (m,) may be queried (module docstring)."""
        ok = lcb >= obs.p_min
        if ok.any():
            ok[ok] = ~self.exclusion.excluded(obs, Z[ok])
        if tr is not None and ok.any():
            ok &= tr.contains(Z)
        if self.failures is not None and (self.relaxed or obs.any_failed) and ok.any():
            ok[ok] = self.failures.acceptable(Z[ok], self.abort_tol, self.crash_tol)
        return ok

    def fit_failures(self, obs: Observations, lengthscales: np.ndarray) -> None:
        """A new failure model with the safety ``lengthscales`` (d,) on every trial (when ``track_failures``)."""
        if self.track_failures:
            self.failures = FailureModel(lengthscales).fit(obs.X, ~obs.complete, obs.crashed)

    def update_failures(self, obs: Observations) -> bool:
        """Whether any trial failed; if so, the failure model is brought up to date with ``obs``."""
        if self.failures is None or not obs.any_failed:
            return False
        self.failures.fit(obs.X, ~obs.complete, obs.crashed)
        return True

    def unlikely_to_abort(self, obs: Observations) -> np.ndarray:
        """(n,) bool: trials the failure model does not expect to abort (all of them while none has failed)."""
        if self.failures is None or not obs.any_failed:
            return np.ones(obs.n, dtype=bool)
        return self.failures.predict(obs.X)[0] <= self.abort_tol

    def acceptable(self, obs: Observations, Z: np.ndarray) -> np.ndarray:
        """(m,) bool: Z (m, d) within the failure tolerances (all True without a failure model)."""
        if self.failures is None:
            return np.ones(Z.shape[0], dtype=bool)
        return self.failures.acceptable(Z, self.abort_tol, self.crash_tol)
