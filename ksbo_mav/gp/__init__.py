"""Gaussian-process machinery: additive kernels (Newton–Girard), exact GP regression, ML-II fitting."""

from ksbo_mav.gp.fitting import FitResult, fit_hyperparameters, log_marginal_likelihood
from ksbo_mav.gp.kernels import AdditiveKernel, Term
from ksbo_mav.gp.linalg import CholeskyError, cholesky_append, jitter_cholesky
from ksbo_mav.gp.regression import GaussianProcess, NotFittedError
from ksbo_mav.gp.symmetric import elementary_symmetric

__all__ = [
    "AdditiveKernel", "CholeskyError", "FitResult", "GaussianProcess", "NotFittedError", "Term",
    "cholesky_append", "elementary_symmetric", "fit_hyperparameters", "jitter_cholesky",
    "log_marginal_likelihood",
]
