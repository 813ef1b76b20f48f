"""ML-II (type-II maximum likelihood) hyperparameter fitting with analytic gradients, bounds, priors, restarts.

Parameters are optimised in log space with L-BFGS-B: the kernel's :attr:`~AdditiveKernel.theta` followed by the
log noise variance (when the noise is fitted). The objective is the negative log marginal likelihood of the
(standardised) targets plus the negative log of an optional log-normal prior on each lengthscale.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from numpy.typing import NDArray
from scipy.optimize import minimize

from ksbo_mav.gp.kernels import AdditiveKernel
from ksbo_mav.gp.linalg import CholeskyError, jitter_cholesky

_LOG_2PI = float(np.log(2 * np.pi))


def log_marginal_likelihood(
    kernel: AdditiveKernel, X: NDArray[np.float64], y: NDArray[np.float64], noise: float, eval_gradient: bool = False
) -> tuple[float, NDArray[np.float64] | None]:
    """Log marginal likelihood ``log p(y | X, theta)`` of a zero-mean GP and its gradient.

    Args:
        kernel: kernel with the hyperparameters to evaluate.
        X: ``(n, D)`` inputs.
        y: ``(n,)`` targets (already standardised if that is wanted).
        noise: noise variance added to the diagonal.
        eval_gradient: also return the gradient.

    Returns:
        The value and, if requested, the ``(p + 1,)`` gradient with respect to ``(kernel.theta, log noise)``.
    """
    n = X.shape[0]
    if eval_gradient:
        K, dK = kernel.value_and_gradient(X)
    else:
        K, dK = kernel(X), None
    L, _ = jitter_cholesky(K + noise * np.eye(n))
    alpha = sla.cho_solve((L, True), y, check_finite=False)
    lml = -0.5 * float(y @ alpha) - float(np.log(np.diag(L)).sum()) - 0.5 * n * _LOG_2PI
    if not eval_gradient:
        return lml, None
    Kinv = sla.cho_solve((L, True), np.eye(n), check_finite=False)
    A = np.outer(alpha, alpha) - Kinv  # (n, n)
    grad_k = 0.5 * np.einsum("ij,pij->p", A, dK)
    grad_noise = 0.5 * noise * float(np.trace(A))
    return lml, np.append(grad_k, grad_noise)


@dataclass
class FitResult:
    """Outcome of :func:`fit_hyperparameters`."""

    kernel: AdditiveKernel
    noise: float
    log_marginal_likelihood: float
    objective: float  #: minimised value (negative LML minus log prior)
    n_failed_starts: int


def fit_hyperparameters(
    kernel: AdditiveKernel,
    X: NDArray[np.float64],
    y: NDArray[np.float64],
    noise: float,
    noise_bounds: tuple[float, float] = (1e-6, 1.0),
    optimize_noise: bool = True,
    lengthscale_prior: tuple[float, float] | None = None,
    n_restarts: int = 3,
    rng: np.random.Generator | None = None,
) -> FitResult:
    """Maximise the (penalised) log marginal likelihood over the kernel's ``theta`` and the noise.

    Args:
        kernel: starting kernel; its ``theta_bounds`` bound the search.
        X: ``(n, D)`` inputs in the unit cube.
        y: ``(n,)`` (standardised) targets.
        noise: starting noise variance.
        noise_bounds: bounds of the noise variance.
        optimize_noise: fit the noise too (else it stays at ``noise``).
        lengthscale_prior: ``(median, log_sd)`` of a log-normal prior on every lengthscale, or ``None``.
        n_restarts: extra starts drawn uniformly (in log space) inside the bounds, besides the current values.
        rng: random generator for the restarts.

    Returns:
        The best :class:`FitResult` over all starts.
    """
    rng = np.random.default_rng() if rng is None else rng
    m = kernel.n_lengthscale_params
    bounds = kernel.theta_bounds
    if optimize_noise:
        bounds = np.vstack([bounds, np.log(np.asarray(noise_bounds, dtype=float))])
    log_noise_fixed = float(np.log(noise))

    def objective(x: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
        theta = x[: len(x) - 1] if optimize_noise else x
        log_noise = float(x[-1]) if optimize_noise else log_noise_fixed
        try:
            lml, grad = log_marginal_likelihood(kernel.with_theta(theta), X, y, float(np.exp(log_noise)), True)
        except CholeskyError:
            return 1e25, np.zeros_like(x)
        assert grad is not None
        val, g = -lml, -grad if optimize_noise else -grad[:-1]
        if lengthscale_prior is not None:
            med, sd = lengthscale_prior
            dz = (x[:m] - np.log(med)) / sd
            val += 0.5 * float(dz @ dz)
            g = g.copy()
            g[:m] += dz / sd
        if not np.isfinite(val):
            return 1e25, np.zeros_like(x)
        return val, g

    x0 = kernel.theta
    if optimize_noise:
        x0 = np.append(x0, log_noise_fixed)
    x0 = np.clip(x0, bounds[:, 0], bounds[:, 1])
    starts = [x0] + [rng.uniform(bounds[:, 0], bounds[:, 1]) for _ in range(max(0, n_restarts))]
    best: tuple[float, NDArray[np.float64]] | None = None
    failed = 0
    for s in starts:
        res = minimize(objective, s, jac=True, method="L-BFGS-B", bounds=bounds)
        if not np.isfinite(res.fun) or res.fun >= 1e25:
            failed += 1
            continue
        if best is None or res.fun < best[0]:
            best = (float(res.fun), np.clip(res.x, bounds[:, 0], bounds[:, 1]))
    if best is None:
        raise CholeskyError("hyperparameter fitting failed from every start (kernel matrix never factorised)")
    x = best[1]
    theta = x[:-1] if optimize_noise else x
    fitted_noise = float(np.exp(x[-1])) if optimize_noise else noise
    fitted = kernel.with_theta(theta)
    lml, _ = log_marginal_likelihood(fitted, X, y, fitted_noise)
    return FitResult(fitted, fitted_noise, lml, best[0], failed)
