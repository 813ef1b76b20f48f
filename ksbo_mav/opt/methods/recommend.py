"""The recommendation: the model's smoothed judgement of the flown points, and their expected score once trials
have failed.

* :meth:`Recommender.model_choice` — among completed observations that were safe *and* are certified by the
  model, the best smoothed posterior mean (or LCB): not the luckiest noisy observation (bistable gains fly well
  from one start and crash from another).
* :func:`expected_value` — a point's mean score over its own flights, weighed by its chance to fail.
* :func:`clear_choice` — the best point the failure model puts clear of every failure.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ksbo_mav.opt.acquisition.certificate import Certificate
from ksbo_mav.opt.acquisition.rules import Posterior
from ksbo_mav.opt.models.safety_model import SafetyModel
from ksbo_mav.opt.observations import Observations

#: The value a failed (aborted or crashed) flight counts with in :func:`expected_value`: the floor of the score.
FAILED_VALUE = -1.0
#: Pseudo-flights of the failure model's neighbourhood estimate in :func:`expected_value`.
NEIGHBOUR_WEIGHT = 2.0
#: :func:`clear_choice`: P(abort) at most this (below the prior mean 0.25: well inside completed trials).
CLEAR_TOL = 0.1


@dataclass(frozen=True)
class Recommender:
    """Judges flown points by ``criterion`` ("mean" or "lcb") of a smoothing GP: the main GP refitted with noise
    std ``noise`` × its signal std (None: the main GP itself), its LCB taken with ``beta``."""

    criterion: str = "lcb"
    noise: float | None = 0.2
    beta: float = 4.0

    def smoothed(self, post: Posterior, model: SafetyModel, obs: Observations) -> tuple[np.ndarray, np.ndarray]:
        """(n,) smoothed posterior mean and (n,) LCB at the data. The smoothing GP averages a lucky flight of a
        bistable gain with its failing neighbours."""
        if self.noise is None:
            mu, _, lcb, _ = post.bounds(obs.X)
            return mu, lcb
        smooth = model.variant(noise_std=self.noise * model.signal_std)
        smooth.fit(*obs.gp_data())
        mu_s, sd_s = smooth.predict(obs.X)
        return mu_s, mu_s - self.beta * sd_s

    def pick(self, mu: np.ndarray, lcb: np.ndarray) -> np.ndarray:
        """The criterion's (n,) values."""
        return lcb if self.criterion == "lcb" else mu

    def model_choice(self, post: Posterior, model: SafetyModel, obs: Observations, cert: Certificate
                     ) -> tuple[int, float, float]:
        """Index into the data of the recommended point, with its smoothed mean and LCB: among completed
        observations that were safe, are certified and the failure model does not expect to abort, the best by
        the criterion."""
        _, _, lcb_strict, _ = post.bounds(obs.X)
        ok = obs.safe_complete() & (lcb_strict >= obs.p_min) & cert.unlikely_to_abort(obs)
        mu, lcb = self.smoothed(post, model, obs)
        if not ok.any():
            ok = obs.safe_complete()
        if not ok.any():
            ok = np.ones_like(ok)
        i = int(np.argmax(np.where(ok, self.pick(mu, lcb), -np.inf)))
        return i, float(mu[i]), float(lcb[i])


def expected_value(obs: Observations, cert: Certificate, i: int) -> float:
    """Expected score of the gains X[i]: ``(1 − p)·m + p·FAILED_VALUE``, with m the mean over the completed
    flights at exactly X[i] and p their chance to fail.

    p = (f + NEIGHBOUR_WEIGHT·q) / (n + NEIGHBOUR_WEIGHT): X[i]'s own f failures in n flights, shrunk towards
    the failure model's P(abort) q there (its neighbours'). The kernel model alone averages a bistable point's
    own failures with many completed neighbours (gains that failed 2 of 5 flights had q = 0.17 on a planar
    tuning seed). Without any failed trial in the run: the mean of all its flights.
    """
    same = obs.at(obs.X[i])
    if cert.failures is None or not obs.any_failed:
        return float(np.mean(obs.y[same]))
    done = same & obs.complete
    m = float(np.mean(obs.y[done])) if done.any() else FAILED_VALUE
    q = float(cert.failures.predict(obs.X[i][None, :])[0][0])
    p = (float(np.sum(same & ~obs.complete)) + NEIGHBOUR_WEIGHT * q) / (float(same.sum()) + NEIGHBOUR_WEIGHT)
    return (1.0 - p) * m + p * FAILED_VALUE


def best_expected(obs: Observations, cert: Certificate, cands: np.ndarray) -> int:
    """Data index of the candidate (``cands`` (k,) data indices) with the best :func:`expected_value` (the first
    of equals)."""
    return max((int(c) for c in cands), key=lambda k: expected_value(obs, cert, k))


def clear_choice(crit: np.ndarray, obs: Observations, cert: Certificate) -> int | None:
    """Data index of the best completed safe point by ``crit`` (n,) that the failure model puts clear of every
    failure (P(abort) ≤ ``CLEAR_TOL``, outside every exclusion ball), or None."""
    if cert.failures is None:
        return None
    ok = obs.safe_complete() & (cert.failures.predict(obs.X)[0] <= CLEAR_TOL) & ~cert.exclusion.excluded(obs, obs.X)
    return int(np.argmax(np.where(ok, crit, -np.inf))) if ok.any() else None
