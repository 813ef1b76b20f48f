"""Choose additive-kernel orders by repeated Nyström C_ree (the paper's Algorithm 1 run T times, top-k kept)."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ksbo_mav.errors import InputError
from ksbo_mav.gp import AdditiveKernel
from ksbo_mav.select.cree import cree_exact, cree_nystrom
from ksbo_mav.select.dims import check_data

#: Defaults (the paper gives none): see ``select_orders``.
DEFAULT_MU = 0.1
DEFAULT_LENGTHSCALE = 0.2
#: Default c / l. The paper gives no c. With c = l (exact) C_ree is a training error that favours flexible
#: high orders; at c ~ 0.8 l the Nyström truncation penalises high orders, and on synthetic functions of known
#: structure (additive, sum of 2-D terms) the top order matches the true one (benchmarks/kernel-selection).
DEFAULT_COLUMN_FRACTION = 0.8


@dataclass
class OrderSelection:
    """Result of :func:`select_orders` (dicts map order -> value)."""

    orders: tuple[int, ...]  #: chosen orders, best (lowest mean C_ree) first
    ranking: tuple[int, ...]  #: all orders, best first
    mean: dict[int, float]
    std: dict[int, float]
    top_frequency: dict[int, float]  #: fraction of trials in which the order ranks within the top ``top``
    exact: dict[int, float]  #: C_ree with c = k = l
    values: NDArray[np.float64] = field(repr=False)  #: (n_orders, trials), rows in the order of the ``orders`` argument
    columns: int = 0
    rank: int = 0
    mu: float = DEFAULT_MU
    trials: int = 0
    top: int = 3
    y_mean: float = 0.0
    y_std: float = 1.0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary."""
        return {
            "orders": list(self.orders),
            "ranking": list(self.ranking),
            "cree": {str(r): v for r, v in self.mean.items()},
            "cree_std": {str(r): v for r, v in self.std.items()},
            "cree_exact": {str(r): v for r, v in self.exact.items()},
            "top_frequency": {str(r): v for r, v in self.top_frequency.items()},
            "settings": {"columns": self.columns, "rank": self.rank, "mu": self.mu, "trials": self.trials,
                         "top": self.top},
        }


def order_kernel_matrices(
    X: NDArray[np.float64], orders: Iterable[int], lengthscales: float | ArrayLike = DEFAULT_LENGTHSCALE,
    normalize: bool = True,
) -> NDArray[np.float64]:
    """``(m, l, l)`` stack of single-order kernel matrices (unit variance per order) on ``X`` of shape ``(l, D)``."""
    return np.stack([AdditiveKernel(X.shape[1], (r,), lengthscales, order_variances=[1.0],
                                    normalize=normalize)(X) for r in orders])


def rank_counts(values: NDArray[np.float64], top: int) -> NDArray[np.float64]:
    """Per row of ``values`` (``(m, T)``, lower better): fraction of columns where it is among the ``top`` lowest."""
    ranks = np.argsort(np.argsort(values, axis=0, kind="stable"), axis=0, kind="stable")
    return (ranks < top).mean(axis=1)


def select_orders(
    X: ArrayLike,
    y: ArrayLike,
    orders: Iterable[int] = range(1, 10),
    trials: int = 1000,
    top: int = 3,
    columns: int | None = None,
    rank: int | None = None,
    mu: float = DEFAULT_MU,
    seed: int | np.random.Generator | None = None,
    lengthscales: float | ArrayLike = DEFAULT_LENGTHSCALE,
    normalize: bool = True,
    standardize: bool = True,
) -> OrderSelection:
    """Rank additive-kernel orders by C_ree averaged over ``trials`` Nyström samples; keep the ``top`` best.

    Each order ``r`` is its own kernel (normalised order-``r`` additive kernel, unit variance, SE base kernels
    with ``lengthscales`` on the unit cube). ``y`` is standardised first (``standardize=True``): C_ree is
    quadratic in ``y`` and the kernels are zero-mean, so an uncentred ``y`` mostly measures its mean; after
    standardising, ``0 < C_ree <= 1`` (times the variance ratio) and ``mu`` is a noise-to-signal ratio.

    Args:
        X: ``(l, D)`` prior inputs in the unit cube.
        y: ``(l,)`` prior observations.
        orders: candidate orders (default 1..9; each must be <= D).
        trials: repetitions ``T`` of Algorithm 1.
        top: number of orders kept.
        columns: ``c`` (default ``round(0.8 l)``, 29 at l = 36; see :data:`DEFAULT_COLUMN_FRACTION`).
        rank: ``k`` (default ``c``).
        mu: Algorithm 1's ``mu`` (``l`` times the kernel-ridge regulariser; default 0.1).
        seed: column-sampling seed.
        lengthscales: base-kernel lengthscale(s) in unit-cube units (default 0.2).
        normalize: divide order ``r`` by ``C(D, r)``.
        standardize: standardise ``y`` (recommended).

    Returns:
        :class:`OrderSelection`.
    """
    X, y = check_data(X, y)
    l, D = X.shape
    orders = tuple(int(r) for r in orders)
    if not orders or len(set(orders)) != len(orders) or min(orders) < 1 or max(orders) > D:
        raise InputError(f"orders must be distinct integers in 1..{D}, got {orders}")
    if l < 2:
        raise InputError("need at least 2 prior points")
    if not (isinstance(top, (int, np.integer)) and 1 <= top <= len(orders)):
        raise InputError(f"top must be in 1..{len(orders)}, got {top!r}")
    c = max(1, round(DEFAULT_COLUMN_FRACTION * l)) if columns is None else columns
    if not (isinstance(c, (int, np.integer)) and 1 <= c <= l):
        raise InputError(f"columns (c) must be in 1..{l} (the number of prior points), got {c!r}")
    k = c if rank is None else rank
    if not (isinstance(k, (int, np.integer)) and 1 <= k <= c):
        raise InputError(f"rank (k) must be in 1..c={c}, got {k!r}")
    y_mean, y_std = float(y.mean()), float(y.std())
    if standardize:
        if y_std <= 1e-12 * max(1.0, abs(y_mean)):
            raise InputError("all prior observations are equal; C_ree cannot rank kernels")
        ys = (y - y_mean) / y_std
    else:
        ys, y_mean, y_std = y, 0.0, 1.0
    Ks = order_kernel_matrices(X, orders, lengthscales, normalize)
    vals = cree_nystrom(Ks, ys, columns=int(c), rank=int(k), mu=mu, trials=trials, seed=seed)
    exact = np.atleast_1d(cree_exact(Ks, ys, mu))
    mean, std = vals.mean(axis=1), vals.std(axis=1)
    freq = rank_counts(vals, int(top))
    order_idx = np.lexsort((-freq, mean))  # by mean, ties by frequency
    ranking = tuple(orders[i] for i in order_idx)
    return OrderSelection(
        orders=ranking[:top], ranking=ranking,
        mean={r: float(v) for r, v in zip(orders, mean)}, std={r: float(v) for r, v in zip(orders, std)},
        top_frequency={r: float(v) for r, v in zip(orders, freq)},
        exact={r: float(v) for r, v in zip(orders, exact)},
        values=vals, columns=int(c), rank=int(k), mu=float(mu), trials=int(trials), top=int(top),
        y_mean=y_mean if standardize else 0.0, y_std=y_std if standardize else 1.0,
    )
