"""Cholesky factorisation with jitter escalation and its rank-one (one new point) extension."""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from numpy.typing import NDArray


class CholeskyError(np.linalg.LinAlgError):
    """The matrix stayed numerically indefinite after the largest jitter."""


def jitter_cholesky(
    A: NDArray[np.float64], jitter0: float = 1e-10, max_jitter: float = 1e-3, start: float = 0.0
) -> tuple[NDArray[np.float64], float]:
    """Lower Cholesky factor of ``A + j I`` with the smallest workable jitter ``j`` on a ×10 ladder.

    Tries ``start`` first (0 by default), then ``jitter0 * s, 10 * jitter0 * s, ...`` up to ``max_jitter * s``,
    where ``s`` is the mean diagonal of ``A`` (so the ladder is scale free).

    Args:
        A: ``(n, n)`` symmetric matrix.
        jitter0: first relative jitter.
        max_jitter: largest relative jitter.
        start: absolute jitter tried first.

    Returns:
        ``L`` of shape ``(n, n)`` (lower) and the absolute jitter added.
    """
    n = A.shape[0]
    scale = float(np.mean(np.diag(A))) if n else 1.0
    scale = scale if np.isfinite(scale) and scale > 0 else 1.0
    ladder = [start]
    j = jitter0 * scale
    while j <= max_jitter * scale * (1 + 1e-12):
        if j > start:
            ladder.append(j)
        j *= 10.0
    for jit in ladder:
        try:
            L = sla.cholesky(A + jit * np.eye(n), lower=True, check_finite=False)
        except np.linalg.LinAlgError:
            continue
        if np.all(np.isfinite(L)) and np.all(np.diag(L) > 0):
            return L, jit
    raise CholeskyError(
        f"kernel matrix is not positive definite even with jitter {max_jitter * scale:.3g}; "
        "duplicate inputs with tiny noise or extreme hyperparameters?"
    )


def cholesky_append(L: NDArray[np.float64], k: NDArray[np.float64], kss: float) -> NDArray[np.float64] | None:
    """Extend the lower factor of ``A`` to that of ``[[A, k], [k^T, kss]]``.

    Args:
        L: ``(n, n)`` lower Cholesky factor of ``A``.
        k: ``(n,)`` new column.
        kss: new diagonal entry (jitter and noise included).

    Returns:
        ``(n + 1, n + 1)`` factor, or ``None`` if the new pivot is not safely positive (refactorise instead).
    """
    n = L.shape[0]
    ell = sla.solve_triangular(L, k, lower=True, check_finite=False) if n else np.zeros(0)
    d2 = kss - float(ell @ ell)
    if not np.isfinite(d2) or d2 <= 1e-12 * max(abs(kss), 1e-300):
        return None
    out = np.zeros((n + 1, n + 1))
    out[:n, :n] = L
    out[n, :n] = ell
    out[n, n] = np.sqrt(d2)
    return out
