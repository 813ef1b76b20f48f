"""Elementary symmetric polynomials of base-kernel values (the engine of additive kernels).

For base-kernel values ``z_1..z_D`` (one per input dimension) the order-``r`` additive kernel is the elementary
symmetric polynomial ``e_r(z) = sum_{i_1<...<i_r} prod_j z_{i_j}`` (Duvenaud, Nickisch & Rasmussen, NeurIPS 2011).
Two O(D*R)-per-entry evaluations are provided, and neither enumerates subsets:

* ``"newton-girard"`` (default, as in GPML's ``elsympol``): power sums ``p_k = sum_i z_i**k`` and the identity
  ``e_r = (1/r) sum_{k=1..r} (-1)**(k-1) e_{r-k} p_k``. It alternates signs, so an entry whose value is far below
  the size of its terms (e.g. ``e_9`` of points that are far apart in one dimension) carries an *absolute* error of
  about ``1e-16 * C(D, r)``; relative to the kernel's scale it is exact to machine precision.
* ``"recursive"``: the summation recurrence ``e_r <- e_r + z_i e_{r-1}`` over dimensions. All terms are
  non-negative, so every entry is accurate to a few ulps *relative to itself*; it is also slightly cheaper.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import NDArray

Method = Literal["newton-girard", "recursive"]
METHODS: tuple[str, ...] = ("newton-girard", "recursive")


def esp_from_power_sums(p: NDArray[np.float64]) -> NDArray[np.float64]:
    """Newton–Girard: elementary symmetric polynomials from power sums.

    Args:
        p: ``(R + 1, ...)`` power sums; ``p[k] = sum_i z_i**k`` for ``k >= 1`` (``p[0]`` is ignored).

    Returns:
        ``(R + 1, ...)`` array ``e`` with ``e[0] = 1`` and ``e[r]`` the order-``r`` polynomial.
    """
    r_max = p.shape[0] - 1
    e = np.empty_like(p)
    e[0] = 1.0
    for r in range(1, r_max + 1):
        acc = e[r - 1] * p[1]
        for k in range(2, r + 1):
            if k % 2:
                acc += e[r - k] * p[k]
            else:
                acc -= e[r - k] * p[k]
        e[r] = acc / r
    return e


def elementary_symmetric(
    z: NDArray[np.float64], max_order: int, method: Method = "newton-girard"
) -> NDArray[np.float64]:
    """Elementary symmetric polynomials ``e_0..e_R`` of ``z`` along its first axis.

    Args:
        z: ``(D, ...)`` values (one slice per dimension).
        max_order: ``R``, highest order returned (``R <= D``).
        method: ``"newton-girard"`` or ``"recursive"`` (see the module docstring).

    Returns:
        ``(R + 1, ...)`` array; ``out[r]`` equals the sum over all ``r``-subsets of the product of their ``z``.
    """
    z = np.asarray(z, dtype=float)
    if method == "newton-girard":
        p = np.empty((max_order + 1,) + z.shape[1:])
        p[0] = z.shape[0]
        zk = np.ones_like(z)
        for k in range(1, max_order + 1):
            zk = zk * z
            p[k] = zk.sum(axis=0)
        return esp_from_power_sums(p)
    if method == "recursive":
        e = np.zeros((max_order + 1,) + z.shape[1:])
        e[0] = 1.0
        for i in range(z.shape[0]):
            for r in range(min(i + 1, max_order), 0, -1):
                e[r] += z[i] * e[r - 1]
        return e
    raise ValueError(f"unknown method {method!r}; expected one of {', '.join(METHODS)}")


def esp_without_one(e: NDArray[np.float64], zi: NDArray[np.float64], max_order: int) -> NDArray[np.float64]:
    """Polynomials of all dimensions except one: ``f_r = e_r(z without z_i)`` for ``r = 0..max_order``.

    Uses ``f_0 = 1``, ``f_r = e_r - z_i f_{r-1}``; ``f_{r-1}`` is ``d e_r / d z_i``, which is what kernel
    gradients need. Absolute error is of the order of machine precision times ``e_r``.

    Args:
        e: ``(>= max_order + 1, ...)`` polynomials of all dimensions.
        zi: ``(...)`` values of the left-out dimension.
        max_order: highest order returned.

    Returns:
        ``(max_order + 1, ...)``.
    """
    f = np.empty((max_order + 1,) + zi.shape)
    f[0] = 1.0
    for r in range(1, max_order + 1):
        f[r] = e[r] - zi * f[r - 1]
    return f
