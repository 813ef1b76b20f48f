"""Exact Gaussian-process regression (numpy/scipy) in the scikit-learn spirit.

Inputs are expected in the unit cube (map physical gains with the profile's ``to_unit`` first). With
``normalize_y=True`` the targets are standardised (mean 0, std 1; std taken as 1 for fewer than two or constant
targets), and ``noise`` is the noise *variance in standardised units* (as scikit-learn's ``alpha``); predictions
are returned in the original units. :meth:`GaussianProcess.predict` gives the latent ``f`` (no observation
noise) and only marginal standard deviations: the joint ``m x m`` covariance is never formed.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from numpy.typing import ArrayLike, NDArray

from ksbo_mav.errors import InputError
from ksbo_mav.gp.fitting import fit_hyperparameters, log_marginal_likelihood
from ksbo_mav.gp.kernels import AdditiveKernel
from ksbo_mav.gp.linalg import cholesky_append, jitter_cholesky


class NotFittedError(InputError):
    """``predict``/``add_observation`` called before ``fit``."""


class GaussianProcess:
    """GP regressor with an :class:`AdditiveKernel`.

    Args:
        kernel: prior covariance (its hyperparameters are the start of ML-II when ``optimize=True``).
        noise: noise variance (standardised units if ``normalize_y``).
        normalize_y: standardise targets.
        optimize: fit kernel hyperparameters (and the noise, if ``optimize_noise``) by ML-II in :meth:`fit`.
        n_restarts: random restarts of ML-II in addition to the start at the current hyperparameters.
        seed: seed of the restarts.
        noise_bounds: bounds of the fitted noise variance.
        optimize_noise: fit the noise in ML-II.
        lengthscale_prior: ``(median, log_sd)`` log-normal prior on each lengthscale during ML-II, or ``None``.

    Attributes (after :meth:`fit`):
        kernel_: kernel with fitted hyperparameters (a copy of ``kernel`` when ``optimize=False``).
        noise_: noise variance in use.
        X_train_: ``(n, D)``; y_train_: ``(n,)`` targets in original units.
        L_: ``(n, n)`` lower Cholesky factor of ``K + (noise_ + jitter_) I``; alpha_: ``(n,)``.
        y_mean_, y_std_: standardisation constants; jitter_: jitter that was needed.
        log_marginal_likelihood_value_: LML of the standardised targets at the fitted hyperparameters.
    """

    def __init__(
        self,
        kernel: AdditiveKernel,
        noise: float = 1e-4,
        normalize_y: bool = True,
        optimize: bool = False,
        n_restarts: int = 3,
        seed: int | None = None,
        noise_bounds: tuple[float, float] = (1e-6, 1.0),
        optimize_noise: bool = True,
        lengthscale_prior: tuple[float, float] | None = None,
    ) -> None:
        self.kernel = kernel
        self.noise = noise
        self.normalize_y = normalize_y
        self.optimize = optimize
        self.n_restarts = n_restarts
        self.seed = seed
        self.noise_bounds = noise_bounds
        self.optimize_noise = optimize_noise
        self.lengthscale_prior = lengthscale_prior

    # ------------------------------------------------------------------ helpers
    def _check_Xy(self, X: ArrayLike, y: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        X = np.asarray(X, dtype=float)
        y = np.asarray(y, dtype=float)
        D = self.kernel.dim
        if X.ndim == 1 and X.shape[0] == D:
            X = X[None, :]
        y = y.reshape(-1) if y.ndim != 1 else y
        if X.ndim != 2 or X.shape[1] != D:
            raise InputError(f"X must have shape (n, {D}), got {X.shape}")
        if X.shape[0] != y.shape[0]:
            raise InputError(f"X has {X.shape[0]} rows but y has {y.shape[0]} values")
        if X.shape[0] == 0:
            raise InputError("cannot fit a GP to zero observations")
        if not (np.all(np.isfinite(X)) and np.all(np.isfinite(y))):
            raise InputError("X and y must be finite (no NaN or inf)")
        return X, y

    def _standardise(self) -> None:
        y = self.y_train_
        if self.normalize_y:
            self.y_mean_ = float(y.mean())
            sd = float(y.std()) if y.size > 1 else 0.0
            self.y_std_ = sd if sd > 1e-12 * max(1.0, abs(self.y_mean_)) else 1.0
        else:
            self.y_mean_, self.y_std_ = 0.0, 1.0
        self._ys = (y - self.y_mean_) / self.y_std_

    def _solve(self) -> None:
        self.alpha_ = sla.cho_solve((self.L_, True), self._ys, check_finite=False)
        self.log_marginal_likelihood_value_ = self._lml()

    def _factorise(self) -> None:
        K = self.kernel_(self.X_train_)
        self.L_, self.jitter_ = jitter_cholesky(K + self.noise_ * np.eye(K.shape[0]))

    def _check_fitted(self) -> None:
        if not hasattr(self, "L_"):
            raise NotFittedError("this GaussianProcess is not fitted yet; call fit(X, y) first")

    # ------------------------------------------------------------------ API
    def fit(self, X: ArrayLike, y: ArrayLike) -> "GaussianProcess":
        """Condition on data (and fit hyperparameters if ``optimize``).

        Args:
            X: ``(n, D)`` inputs in the unit cube.
            y: ``(n,)`` observations.

        Returns:
            ``self``.
        """
        X, y = self._check_Xy(X, y)
        if not (np.isfinite(self.noise) and self.noise > 0):
            raise InputError(f"noise must be a positive variance, got {self.noise!r}")
        self.X_train_, self.y_train_ = X.copy(), y.copy()
        self.kernel_ = self.kernel.clone()
        self.noise_ = float(self.noise)
        self._standardise()
        if self.optimize:
            res = fit_hyperparameters(
                self.kernel_, X, self._ys, self.noise_, self.noise_bounds, self.optimize_noise,
                self.lengthscale_prior, self.n_restarts, np.random.default_rng(self.seed),
            )
            self.kernel_, self.noise_ = res.kernel, res.noise
        self._factorise()
        self._solve()
        return self

    def _lml(self) -> float:
        n = self._ys.shape[0]
        return float(-0.5 * self._ys @ self.alpha_ - np.log(np.diag(self.L_)).sum() - 0.5 * n * np.log(2 * np.pi))

    def log_marginal_likelihood(self, kernel: AdditiveKernel | None = None, noise: float | None = None) -> float:
        """LML of the standardised training targets under ``kernel``/``noise`` (default: the fitted ones)."""
        self._check_fitted()
        k = self.kernel_ if kernel is None else kernel
        nz = self.noise_ if noise is None else noise
        return log_marginal_likelihood(k, self.X_train_, self._ys, nz)[0]

    def predict(
        self, X: ArrayLike, return_std: bool = False
    ) -> NDArray[np.float64] | tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Posterior of the latent function.

        Args:
            X: ``(m, D)`` candidates in the unit cube.
            return_std: also return marginal standard deviations.

        Returns:
            ``mean`` of shape ``(m,)``, and ``std`` of shape ``(m,)`` if ``return_std`` (original units).
        """
        self._check_fitted()
        X = np.asarray(X, dtype=float)
        if X.ndim == 1 and X.shape[0] == self.kernel.dim:
            X = X[None, :]
        if X.ndim != 2 or X.shape[1] != self.kernel.dim:
            raise InputError(f"X must have shape (m, {self.kernel.dim}), got {X.shape}")
        Ks = self.kernel_(self.X_train_, X)  # (n, m)
        mean = Ks.T @ self.alpha_ * self.y_std_ + self.y_mean_
        if not return_std:
            return mean
        V = sla.solve_triangular(self.L_, Ks, lower=True, check_finite=False)
        var = self.kernel_.diag(X) - np.einsum("ij,ij->j", V, V)
        std = np.sqrt(np.clip(var, 0.0, None)) * self.y_std_
        return mean, std

    def add_observation(self, x: ArrayLike, y: float | ArrayLike) -> "GaussianProcess":
        """Add one observation without changing hyperparameters (rank-one Cholesky extension).

        The result equals ``fit`` on the enlarged data with ``optimize=False`` and the same kernel, noise and
        jitter (the standardisation constants are recomputed). Falls back to a full refactorisation when the new
        pivot is numerically unsafe (e.g. a repeated input with tiny noise).

        Args:
            x: ``(D,)`` or ``(1, D)`` input in the unit cube.
            y: scalar observation.

        Returns:
            ``self``.
        """
        self._check_fitted()
        x2, y1 = self._check_Xy(np.asarray(x, dtype=float).reshape(1, -1), np.asarray(y, dtype=float).reshape(-1))
        k = self.kernel_(self.X_train_, x2)[:, 0]
        kss = float(self.kernel_.diag(x2)[0]) + self.noise_ + self.jitter_
        L = cholesky_append(self.L_, k, kss)
        self.X_train_ = np.vstack([self.X_train_, x2])
        self.y_train_ = np.append(self.y_train_, y1)
        if L is None:
            self._factorise()
        else:
            self.L_ = L
        self._standardise()
        self._solve()
        return self
