"""Nyström approximate kernel selection: C_ree of Algorithm 1 (Zheng et al., arXiv 2411.07573), exact and sampled.

Algorithm 1, per kernel matrix ``K`` (``l x l``) on the prior data ``(X, y)``:

1. sample ``c`` distinct column indices ``I`` (uniformly, without replacement);
2. ``C = K[:, I]`` (``l x c``), ``W = K[I, I]`` (``c x c``);
3. ``W = U_W S_W U_W^T`` (``W`` is symmetric positive semi-definite, so its SVD is its eigendecomposition;
   computed with ``eigh``);
4. ``V = C U_{W,k} (S_{W,k}^+)^{1/2}`` (top ``k`` singular values; pseudo-inverse drops values below
   ``c * eps * max(S_W)``);
5. solve ``(mu I_k + V^T V) t = V^T y``;
6. ``u = (y - V t) / (mu l)``;
7. ``C_ree = mu y^T u``. Lower is better.

By Woodbury, ``C_ree = (mu / l) y^T (V V^T + mu I)^{-1} y``; with ``c = k = l`` it is exactly
:func:`cree_exact` ``= (mu / l) y^T (K + mu I)^{-1} y``.

**mu convention**: ``mu`` is Algorithm 1's ``mu``, i.e. the ridge added to the diagonal of the kernel matrix.
It equals ``l`` times the kernel-ridge regulariser ``mu'`` of ``(1/l) sum (f(x_i) - y_i)^2 + mu' ||f||_K^2``
(whose optimal value is C_ree). With unit-variance kernels and standardised ``y`` it plays the role of a
noise-to-signal variance ratio.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from numpy.typing import ArrayLike, NDArray
from threadpoolctl import threadpool_limits

from ksbo_mav.errors import InputError

#: Trials processed per batch (bounds memory at about 9 kernels x 250 trials x l x c doubles).
_TRIAL_BATCH = 250


def _check_Ky(K: ArrayLike, y: ArrayLike, mu: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    K = np.asarray(K, dtype=float)
    y = np.asarray(y, dtype=float)
    if K.ndim < 2 or K.shape[-1] != K.shape[-2]:
        raise InputError(f"kernel matrix must be square (l, l) or a stack (m, l, l), got {K.shape}")
    if y.shape != (K.shape[-1],):
        raise InputError(f"y must have shape ({K.shape[-1]},), got {y.shape}")
    if not (np.isfinite(mu) and mu > 0):
        raise InputError(f"mu must be positive, got {mu!r}")
    if not (np.all(np.isfinite(K)) and np.all(np.isfinite(y))):
        raise InputError("kernel matrix and y must be finite")
    return K, y


def cree_exact(K: ArrayLike, y: ArrayLike, mu: float) -> float | NDArray[np.float64]:
    """Exact criterion ``(mu / l) y^T (K + mu I)^{-1} y`` (Algorithm 1 with ``c = k = l``).

    Args:
        K: ``(l, l)`` kernel matrix, or ``(m, l, l)`` stack (one per kernel).
        y: ``(l,)`` targets.
        mu: Algorithm 1's ``mu`` (see the module docstring).

    Returns:
        A float, or ``(m,)`` values for a stack.
    """
    K, y = _check_Ky(K, y, mu)
    stack = K.reshape((-1,) + K.shape[-2:])
    l = K.shape[-1]
    out = np.empty(stack.shape[0])
    for j, Kj in enumerate(stack):
        cf = sla.cho_factor(Kj + mu * np.eye(l), lower=True, check_finite=False)
        out[j] = mu / l * float(y @ sla.cho_solve(cf, y, check_finite=False))
    return float(out[0]) if K.ndim == 2 else out.reshape(K.shape[:-2])


def sample_columns(l: int, columns: int, trials: int, rng: np.random.Generator) -> NDArray[np.intp]:
    """``(trials, columns)`` index sets, each drawn uniformly without replacement from ``range(l)``."""
    return np.argsort(rng.random((trials, l)), axis=1)[:, :columns]


def cree_nystrom(
    K: ArrayLike,
    y: ArrayLike,
    columns: int,
    rank: int | None = None,
    mu: float = 0.1,
    trials: int = 1,
    seed: int | np.random.Generator | None = None,
    indices: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Algorithm 1's C_ree over repeated column samples, vectorised over trials (and kernels).

    All kernels of a stack share the same column samples in each trial (paired comparison).

    Args:
        K: ``(l, l)`` kernel matrix or ``(m, l, l)`` stack.
        y: ``(l,)`` targets (standardise them first; see :func:`select_orders`).
        columns: ``c``, sampled columns per trial (``1 <= c <= l``).
        rank: ``k``, rank kept from ``W`` (default ``c``; ``1 <= k <= c``).
        mu: Algorithm 1's ``mu``.
        trials: number of independent column samples ``T``.
        seed: seed or generator for the samples.
        indices: optional ``(T, c)`` explicit column indices (overrides ``columns``/``trials``/``seed``).

    Returns:
        ``(T,)`` values for one matrix, ``(m, T)`` for a stack.
    """
    K, y = _check_Ky(K, y, mu)
    single = K.ndim == 2
    Ks = K.reshape((-1,) + K.shape[-2:])
    l = Ks.shape[-1]
    if indices is not None:
        idx = np.asarray(indices)
        if idx.ndim != 2 or not np.issubdtype(idx.dtype, np.integer) or idx.min() < 0 or idx.max() >= l:
            raise InputError(f"indices must be a (trials, c) integer array with values in 0..{l - 1}")
        columns = idx.shape[1]
    else:
        if not (isinstance(columns, (int, np.integer)) and 1 <= columns <= l):
            raise InputError(f"columns (c) must be an integer in 1..{l}, got {columns!r}")
        if not (isinstance(trials, (int, np.integer)) and trials >= 1):
            raise InputError(f"trials must be a positive integer, got {trials!r}")
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        idx = sample_columns(l, int(columns), int(trials), rng)
    k = int(columns if rank is None else rank)
    if not 1 <= k <= columns:
        raise InputError(f"rank (k) must be an integer in 1..c={columns}, got {rank!r}")
    # C_ree depends on the *set* I only (reordering I permutes C's columns and W consistently), so each distinct
    # set is computed once: exact, and a large saving when c is close to l (c = l - 1 has only l distinct sets).
    uniq, inverse = np.unique(np.sort(idx, axis=1), axis=0, return_inverse=True)
    vals = np.empty((Ks.shape[0], uniq.shape[0]))
    # Thousands of tiny (c x c) problems: multi-threaded BLAS only adds overhead (6x slower on a busy 2-core box).
    with threadpool_limits(limits=1, user_api="blas"):
        for a in range(0, uniq.shape[0], _TRIAL_BATCH):
            vals[:, a:a + _TRIAL_BATCH] = _cree_batch(Ks, y, uniq[a:a + _TRIAL_BATCH], k, mu)
    out = vals[:, inverse.reshape(-1)]
    return out[0] if single else out.reshape(K.shape[:-2] + (idx.shape[0],))


def _cree_batch(
    Ks: NDArray[np.float64], y: NDArray[np.float64], idx: NDArray[np.intp], k: int, mu: float
) -> NDArray[np.float64]:
    """Steps 2–7 for ``(m, l, l)`` matrices and ``(T, c)`` index sets; returns ``(m, T)``."""
    l = Ks.shape[-1]
    C = np.moveaxis(Ks[:, :, idx], 1, 2)  # (m, T, l, c): C[j, t] = K_j[:, I_t]
    W = np.take_along_axis(C, idx[None, :, :, None], axis=2)  # (m, T, c, c): rows I_t of C
    W = 0.5 * (W + np.swapaxes(W, -1, -2))
    s, U = np.linalg.eigh(W)  # ascending
    s, U = s[..., ::-1][..., :k], U[..., ::-1][..., :k]  # top-k part
    tol = W.shape[-1] * np.finfo(float).eps * np.maximum(s[..., :1], 0.0)
    inv_sqrt = np.where(s > tol, 1.0 / np.sqrt(np.where(s > tol, s, 1.0)), 0.0)
    V = (C @ U) * inv_sqrt[..., None, :]  # (m, T, l, k)
    A = np.swapaxes(V, -1, -2) @ V
    A[..., np.arange(k), np.arange(k)] += mu
    rhs = np.swapaxes(V, -1, -2) @ y  # (m, T, k)
    t = np.linalg.solve(A, rhs[..., None])[..., 0]
    u = (y - (V @ t[..., None])[..., 0]) / (mu * l)
    return mu * (u @ y)
