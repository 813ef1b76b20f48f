"""The structure of an additive kernel: which interaction order runs over which dimensions (dropped dimensions
included as first-order terms when asked), and each term's prior variance. Validated here, once."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError


@dataclass(frozen=True)
class Term:
    """One additive term: interaction order ``order`` over the dimensions ``dims`` (sorted, unique)."""

    order: int
    dims: tuple[int, ...]


def resolve_terms(D: int, orders_arg: Any, active_dims: Sequence[int] | Mapping[int, Sequence[int]] | None,
                  inactive_in_order1: bool) -> tuple[list[int], list[Term], tuple[int, ...], bool]:
    """``(orders, terms, dropped dims, extra order-1 term appended?)`` for ``D`` input dimensions (see
    :class:`ksbo_mav.gp.kernels.AdditiveKernel`)."""
    arr = np.atleast_1d(np.asarray(orders_arg))
    if arr.ndim != 1 or (arr.size and not np.issubdtype(arr.dtype, np.integer)):
        raise InputError(f"orders must be a sequence of integers, got {orders_arg!r}")
    orders = [int(r) for r in arr]
    if not orders or len(set(orders)) != len(orders):
        raise InputError(f"orders must be a non-empty sequence of distinct integers, got {orders_arg!r}")

    def check_dims(dims: Sequence[int], what: str) -> tuple[int, ...]:
        arr = np.asarray(dims)
        if arr.ndim != 1 or arr.size == 0 or not np.issubdtype(arr.dtype, np.integer):
            raise InputError(f"{what} must be a non-empty sequence of integer indices, got {dims!r}")
        if arr.min() < 0 or arr.max() >= D or len(set(arr.tolist())) != arr.size:
            raise InputError(f"{what} must be distinct indices in 0..{D - 1}, got {list(arr)}")
        return tuple(sorted(int(i) for i in arr))

    if active_dims is None:
        sets = {r: tuple(range(D)) for r in orders}
    elif isinstance(active_dims, Mapping):
        missing = [r for r in orders if r not in active_dims]
        if missing:
            raise InputError(f"active_dims has no dimensions for order(s) {missing}")
        sets = {r: check_dims(active_dims[r], f"active_dims[{r}]") for r in orders}
    else:
        common = check_dims(active_dims, "active_dims")
        sets = {r: common for r in orders}
    used = set().union(*sets.values())
    dropped = tuple(i for i in range(D) if i not in used)
    terms = []
    for r in orders:
        dims = sets[r]
        if r == 1 and inactive_in_order1 and dropped:
            dims = tuple(sorted(set(dims) | set(dropped)))
        if not 1 <= r <= len(dims):
            raise InputError(f"order {r} needs 1 <= order <= number of its dimensions ({len(dims)})")
        terms.append(Term(r, dims))
    extra = bool(inactive_in_order1 and dropped and 1 not in orders)
    if extra:
        terms.append(Term(1, dropped))
    return orders, terms, dropped, extra


def term_variances(orders: list[int], n_terms: int, extra: bool, order_variances: Any,
                   inactive_variance: float | None) -> np.ndarray:
    """(n_terms,) prior variance of each term: ``1 / n_terms`` unless given per order (sequence or mapping)."""
    default = 1.0 / n_terms
    ov = order_variances
    if ov is None:
        var = [default] * len(orders)
    elif isinstance(ov, Mapping):
        unknown = [r for r in ov if int(r) not in orders]
        if unknown:
            raise InputError(f"order_variances names order(s) {unknown} not in orders {orders}")
        var = [float(ov.get(r, default)) for r in orders]
    else:
        arr = np.atleast_1d(np.asarray(ov, dtype=float))
        if arr.shape != (len(orders),):
            raise InputError(f"order_variances must have one value per order ({len(orders)}), got {arr.shape}")
        var = arr.tolist()
    if extra:
        var.append(default if inactive_variance is None else float(inactive_variance))
    variances = np.asarray(var, dtype=float)
    if not np.all(np.isfinite(variances)) or np.any(variances <= 0):
        raise InputError(f"term variances must be positive and finite, got {variances.tolist()}")
    return variances
