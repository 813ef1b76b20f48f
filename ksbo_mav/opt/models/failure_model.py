"""What the adaptive safe BO learns about failures: the safety scale and the chance a trial aborts.

* :func:`learn_scales` — per-dimension lengthscales of the SE-ARD safety GP by marginal likelihood with a
  log-normal hyperprior, on completed trials; the signal and noise scales stay fixed, so far from the data the
  safety bound still reverts to "on the threshold, full prior uncertainty".
* :class:`FailureModel` — the probability that a trial at z aborts (any non-complete outcome) and that it
  crashes (the backup did not recover): a kernel-weighted Beta–Bernoulli estimate
  ``p(z) = (a + Σ w_i f_i) / (a + b + Σ w_i)``, ``w_i = exp(−½ Σ_j ((z_j − x_ij)/ℓ_j)²)``, with the safety
  lengthscales ℓ. Aborted trials enter it as labels (censored observations: their P is never used as a value).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ksbo_mav.gp import AdditiveKernel
from ksbo_mav.gp.fitting import fit_hyperparameters
from ksbo_mav.gp.linalg import CholeskyError


def learn_scales(
    X: np.ndarray, g: np.ndarray, signal_std: float, noise_std: float, start: np.ndarray,
    prior: tuple[float, float] = (0.1, 1.0), bounds: tuple[float, float] = (0.01, 1.0),
    rng: np.random.Generator | None = None, extent_factor: float | None = 2.0, restarts: int = 1,
) -> tuple[np.ndarray, float]:
    """ML-II (MAP) per-dimension lengthscales of an SE-ARD GP, signal and noise fixed.

    Args:
        X: (n, d) unit-cube inputs of completed trials; g: (n,) safety margins y − p_min.
        signal_std, noise_std: the GP's scales.
        start: (d,) current lengthscales (first start).
        prior: (median, log-sd) of the log-normal hyperprior on each lengthscale. bounds: lengthscale bounds.
        extent_factor: no lengthscale exceeds this many times the extent (max − min) of the data along its
            dimension (nor falls below ``bounds[0]`` for it): the model may not claim smoothness over a range
            it has not seen. With few points the marginal likelihood prefers long scales (a near-constant
            function explains two close points best); this cap makes the safe set grow with the data instead.
        restarts: random starts besides ``start`` (0 = a warm-started refit from the previous optimum).
    Returns:
        (d,) lengthscales (``start`` clipped to the caps if every start failed) and the noise std.
    """
    upper = np.full(X.shape[1], bounds[1])
    if extent_factor is not None:
        upper = np.clip(extent_factor * (X.max(axis=0) - X.min(axis=0)), bounds[0], bounds[1])
    ls = _ml_scales(X, g, signal_std, noise_std, start, prior, bounds, rng, restarts)
    return np.minimum(ls, upper), float(noise_std)


def _ml_scales(X: np.ndarray, g: np.ndarray, signal_std: float, noise_std: float, start: np.ndarray,
               prior: tuple[float, float], bounds: tuple[float, float], rng: np.random.Generator | None,
               restarts: int) -> np.ndarray:
    d = X.shape[1]
    v = float(signal_std) ** 2
    k = AdditiveKernel(dim=d, orders=(d,), lengthscales=np.clip(np.asarray(start, float), *bounds),
                       order_variances=np.array([v]), normalize=True, lengthscale_bounds=bounds,
                       variance_bounds=(v * (1 - 1e-9), v * (1 + 1e-9)))
    try:
        res = fit_hyperparameters(k, X, np.asarray(g, float), float(noise_std) ** 2, noise_bounds=(1e-6, 1.0),
                                  optimize_noise=False, lengthscale_prior=prior, n_restarts=restarts, rng=rng)
    except CholeskyError:
        return np.asarray(start, dtype=float)
    return np.asarray(res.kernel.lengthscales, dtype=float).reshape(-1) * np.ones(d)


@dataclass
class FailureModel:
    """Kernel Beta–Bernoulli model of P(abort) and P(crash) (module docstring).

    Attributes:
        lengthscales: (d,) kernel lengthscales (the safety GP's). abort_prior, crash_prior: (a, b) pseudo-counts
            of failures and successes far from any trial (prior means 0.25 and 0.05).
    """

    lengthscales: np.ndarray
    abort_prior: tuple[float, float] = (0.5, 1.5)
    crash_prior: tuple[float, float] = (0.1, 1.9)
    X: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    failed: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    crashed: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))

    def fit(self, X: np.ndarray, failed: np.ndarray, crashed: np.ndarray) -> "FailureModel":
        """All trials so far: X (n, d), failed (n,) bool (aborted or crashed), crashed (n,) bool."""
        self.X = np.asarray(X, dtype=float)
        self.failed = np.asarray(failed, dtype=bool)
        self.crashed = np.asarray(crashed, dtype=bool)
        return self

    def predict(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(m,) P(abort) and (m,) P(crash) at Z (m, d)."""
        Z = np.atleast_2d(Z)
        if self.X.shape[0] == 0:
            a, b = self.abort_prior
            c, e = self.crash_prior
            return np.full(Z.shape[0], a / (a + b)), np.full(Z.shape[0], c / (c + e))
        ls = np.asarray(self.lengthscales, dtype=float)
        d2 = (((Z[:, None, :] - self.X[None, :, :]) / ls) ** 2).sum(-1)  # (m, n)
        w = np.exp(-0.5 * d2)
        sw = w.sum(axis=1)
        a, b = self.abort_prior
        c, e = self.crash_prior
        p_abort = (a + w @ self.failed.astype(float)) / (a + b + sw)
        p_crash = (c + w @ self.crashed.astype(float)) / (c + e + sw)
        return p_abort, p_crash

    def acceptable(self, Z: np.ndarray, abort_tol: float, crash_tol: float) -> np.ndarray:
        """(m,) bool: Z (m, d) predicted to abort with probability ≤ ``abort_tol`` and crash with ≤ ``crash_tol``."""
        p_abort, p_crash = self.predict(Z)
        return (p_abort <= abort_tol) & (p_crash <= crash_tol)
