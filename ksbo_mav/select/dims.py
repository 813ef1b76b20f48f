"""Dimension (base-kernel) selection for each chosen order: random-forest or permutation importance.

The paper ranks the 9 dimensions "within each kept order" with a random-forest regressor and rebuilds the kernel
"adjusting the frequency with which each base kernel appears"; the rule is not given. Ours:

* importances: ``method="forest"`` uses the forest's impurity (MDI) ``feature_importances_``;
  ``method="permutation"`` uses :func:`sklearn.inspection.permutation_importance` on held-out folds (K-fold, so
  an over-fitted forest cannot inflate noise dimensions; see scikit-learn's MDI-vs-permutation example).
  Negative permutation importances are clipped to 0 and importances are normalised to sum to 1.
* kept dimensions of order ``r``: those with share ``>= threshold / D`` (default: at least half of a uniform
  share), then at least ``max(r, min_dims)`` of the most important, and at most ``top_m`` if given.
  The order enters through this minimum (an order-``r`` term needs ``r`` dimensions) and, optionally, through
  ``max_depth="order"``, which limits the trees to depth ``r`` (a depth-``r`` tree expresses interactions of
  order ``<= r``).
* dropped dimensions: see :class:`~ksbo_mav.gp.AdditiveKernel` (``inactive_in_order1``): by default they stay in
  the kernel as first-order (additive) terms; with ``inactive_in_order1=False`` they are ignored by the GP and the
  optimiser must hold them at the safe start gains.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from sklearn.ensemble import RandomForestRegressor
from sklearn.inspection import permutation_importance
from sklearn.model_selection import KFold

from ksbo_mav.errors import InputError
from ksbo_mav.gp import AdditiveKernel

DEFAULT_THRESHOLD = 0.5


@dataclass
class DimensionSelection:
    """Result of :func:`select_dimensions`."""

    order: int
    dims: tuple[int, ...]  #: kept dimension indices, most important first
    importances: NDArray[np.float64]  #: (D,) normalised shares (sum 1, or all 0 if nothing is predictive)
    importances_std: NDArray[np.float64]  #: (D,) spread over trees (forest) or repeats/folds (permutation)
    method: str
    threshold: float

    def to_dict(self, names: Sequence[str] | None = None) -> dict[str, Any]:
        label = (lambda i: names[i]) if names is not None else (lambda i: i)
        return {"order": self.order, "dims": [label(i) for i in self.dims], "method": self.method,
                "importances": {str(label(i)): float(v) for i, v in enumerate(self.importances)}}


def _forest(n_estimators: int, max_depth: int | None, seed: int | None) -> RandomForestRegressor:
    return RandomForestRegressor(n_estimators=n_estimators, max_depth=max_depth, random_state=seed, n_jobs=1)


def check_data(X: ArrayLike, y: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Inputs (n, D) and targets (n,) as finite float arrays, else :class:`InputError`."""
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    if X.ndim != 2 or y.shape != (X.shape[0],):
        raise InputError(f"X must be (n, D) and y (n,), got {X.shape} and {y.shape}")
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(y))):
        raise InputError("X and y must be finite (no NaN or inf)")
    return X, y


def _check(X: ArrayLike, y: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    X, y = check_data(X, y)
    if X.shape[0] < 3:
        raise InputError("need at least 3 points to rank dimensions")
    return X, y


def feature_importances(
    X: ArrayLike,
    y: ArrayLike,
    method: Literal["forest", "permutation"] = "forest",
    n_estimators: int = 200,
    max_depth: int | None = None,
    n_repeats: int = 5,
    n_splits: int = 4,
    seed: int | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Normalised importance shares of the input dimensions.

    Args:
        X: ``(n, D)`` inputs; y: ``(n,)`` observations.
        method: ``"forest"`` (impurity importance) or ``"permutation"`` (held-out permutation importance).
        n_estimators: trees per forest. max_depth: tree depth (``None``: full trees).
        n_repeats: permutations per feature and fold. n_splits: K-fold splits (training data if ``n < 2 K``).
        seed: random seed.

    Returns:
        ``share`` ``(D,)`` (non-negative, sum 1, or all 0 if nothing is predictive) and its spread ``(D,)``.
    """
    X, y = _check(X, y)
    n, D = X.shape
    if method == "forest":
        rf = _forest(n_estimators, max_depth, seed).fit(X, y)
        raw = rf.feature_importances_
        spread = np.array([t.feature_importances_ for t in rf.estimators_]).std(axis=0)
    elif method == "permutation":
        if n >= 2 * n_splits:
            folds = list(KFold(n_splits, shuffle=True, random_state=seed).split(X))
        else:
            folds = [(np.arange(n), np.arange(n))]
        runs = []
        for f, (tr, te) in enumerate(folds):
            sub = None if seed is None else seed + f
            rf = _forest(n_estimators, max_depth, sub).fit(X[tr], y[tr])
            runs.append(permutation_importance(rf, X[te], y[te], n_repeats=n_repeats, random_state=sub).importances)
        allruns = np.concatenate(runs, axis=1)  # (D, folds * n_repeats)
        raw, spread = allruns.mean(axis=1), allruns.std(axis=1)
    else:
        raise InputError(f"method must be 'forest' or 'permutation', got {method!r}")
    raw = np.clip(np.asarray(raw, dtype=float), 0.0, None)
    total = float(raw.sum())
    if total <= 0:
        return np.zeros(D), np.zeros(D)
    return raw / total, np.asarray(spread, dtype=float) / total


def keep_dimensions(
    share: NDArray[np.float64], order: int, threshold: float = DEFAULT_THRESHOLD, top_m: int | None = None,
    min_dims: int = 1,
) -> tuple[int, ...]:
    """The keep rule (module docstring): share ``>= threshold / D``, at least ``max(order, min_dims)``, at most
    ``top_m``; most important first. All dimensions are kept when every share is 0."""
    D = share.shape[0]
    if not 1 <= order <= D:
        raise InputError(f"order must be in 1..{D}, got {order}")
    if top_m is not None and not order <= top_m <= D:
        raise InputError(f"top_m must be in {order}..{D} for order {order}, got {top_m}")
    rank = [int(i) for i in np.argsort(-share, kind="stable")]
    if share.sum() <= 0:
        keep = list(range(D))
    else:
        keep = [i for i in rank if share[i] >= threshold / D]
        keep += [i for i in rank if i not in keep][: max(0, max(order, min_dims) - len(keep))]
    keep.sort(key=lambda i: (-share[i], i))
    return tuple(keep[:top_m] if top_m is not None else keep)


def select_dimensions(
    X: ArrayLike,
    y: ArrayLike,
    order: int,
    method: Literal["forest", "permutation"] = "forest",
    threshold: float = DEFAULT_THRESHOLD,
    top_m: int | None = None,
    min_dims: int = 1,
    n_estimators: int = 200,
    max_depth: int | Literal["order"] | None = None,
    n_repeats: int = 5,
    n_splits: int = 4,
    seed: int | None = None,
) -> DimensionSelection:
    """Rank the input dimensions by importance and keep the important ones for one interaction order.

    Args:
        X: ``(n, D)`` inputs (unit cube).
        y: ``(n,)`` observations.
        order: the interaction order ``r`` the dimensions are for (at least ``r`` are kept).
        method: ``"forest"`` (impurity importance, the paper's) or ``"permutation"`` (held-out permutation).
        threshold: keep dimensions whose share is ``>= threshold / D``.
        top_m: keep at most this many (default: no cap).
        min_dims: keep at least this many (and at least ``order``).
        n_estimators: trees in the forest.
        max_depth: tree depth; ``"order"`` uses ``order``; ``None`` grows full trees.
        n_repeats: permutations per feature and fold (``method="permutation"``).
        n_splits: folds for held-out permutation importance.
        seed: random seed (forest and permutations).

    Returns:
        :class:`DimensionSelection`.
    """
    X, y = _check(X, y)
    if not 1 <= order <= X.shape[1]:
        raise InputError(f"order must be in 1..{X.shape[1]}, got {order}")
    depth = order if max_depth == "order" else max_depth
    share, spread = feature_importances(X, y, method, n_estimators, depth, n_repeats, n_splits, seed)
    keep = keep_dimensions(share, order, threshold, top_m, min_dims)
    return DimensionSelection(order, keep, share, spread, method, float(threshold))


def select_dimensions_for_orders(
    X: ArrayLike, y: ArrayLike, orders: Iterable[int], **kwargs: Any
) -> dict[int, DimensionSelection]:
    """:func:`select_dimensions` for each order (same keyword arguments). The importances are computed once
    unless ``max_depth="order"`` makes them order dependent."""
    orders = [int(r) for r in orders]
    if kwargs.get("max_depth") == "order":
        return {r: select_dimensions(X, y, r, **kwargs) for r in orders}
    X, y = _check(X, y)
    imp_keys = ("method", "n_estimators", "max_depth", "n_repeats", "n_splits", "seed")
    keep_keys = ("threshold", "top_m", "min_dims")
    unknown = set(kwargs) - set(imp_keys) - set(keep_keys)
    if unknown:
        raise TypeError(f"unexpected keyword argument(s): {', '.join(sorted(unknown))}")
    share, spread = feature_importances(X, y, **{k: v for k, v in kwargs.items() if k in imp_keys})
    kk = {k: v for k, v in kwargs.items() if k in keep_keys}
    return {r: DimensionSelection(r, keep_dimensions(share, r, **kk), share, spread,
                                  kwargs.get("method", "forest"), float(kk.get("threshold", DEFAULT_THRESHOLD)))
            for r in orders}


def kernel_from_selection(
    dim: int, dims: Mapping[int, Sequence[int] | DimensionSelection], **kernel_kwargs: Any
) -> AdditiveKernel:
    """The additive kernel of the selected orders, each over its kept dimensions.

    Args:
        dim: number of inputs ``D``.
        dims: ``order -> kept dimensions`` (or the :class:`DimensionSelection` of that order).
        **kernel_kwargs: other :class:`~ksbo_mav.gp.AdditiveKernel` arguments (lengthscales, inactive_in_order1...).

    Returns:
        ``AdditiveKernel(dim, orders=tuple(dims), active_dims={order: dims}, ...)``.
    """
    active = {int(r): tuple(v.dims if isinstance(v, DimensionSelection) else v) for r, v in dims.items()}
    return AdditiveKernel(dim, orders=tuple(active), active_dims=active, **kernel_kwargs)
