"""Prior designs: Latin hypercube samples over the whole unit cube or inside a trust region around a point."""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.stats import qmc

from ksbo_mav.errors import InputError

DEFAULT_RADIUS = 0.1


def local_box(center: ArrayLike, radius: float | ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(lower, upper)`` of the box ``center +- radius`` intersected with the unit cube (each ``(D,)``)."""
    c = np.asarray(center, dtype=float)
    r = np.broadcast_to(np.asarray(radius, dtype=float), c.shape)
    return np.clip(c - r, 0.0, 1.0), np.clip(c + r, 0.0, 1.0)


def lhs_design(
    n: int,
    dim: int,
    design: Literal["box", "local"] = "box",
    center: ArrayLike | None = None,
    radius: float | ArrayLike = DEFAULT_RADIUS,
    seed: int | np.random.Generator | None = None,
    optimization: Literal["random-cd", "lloyd"] | None = None,
) -> NDArray[np.float64]:
    """Latin hypercube design in the unit cube (``scipy.stats.qmc.LatinHypercube``).

    ``design="box"`` samples the whole cube (the paper's setting). ``design="local"`` samples the trust region
    ``center +- radius`` clipped to the cube (a prior that stays near the safe start gains); the Latin
    hypercube is drawn in that clipped box, so every point is inside it and its strata are kept.

    Args:
        n: number of points.
        dim: dimension ``D``.
        design: ``"box"`` or ``"local"``.
        center: ``(D,)`` trust-region centre in the unit cube (required for ``"local"``).
        radius: half-width(s) of the trust region in unit-cube units (scalar or ``(D,)``).
        seed: random seed or generator.
        optimization: optional scipy LHS optimisation scheme.

    Returns:
        ``(n, D)`` points.
    """
    if not (isinstance(n, (int, np.integer)) and n >= 1):
        raise InputError(f"n must be a positive integer, got {n!r}")
    if not (isinstance(dim, (int, np.integer)) and dim >= 1):
        raise InputError(f"dim must be a positive integer, got {dim!r}")
    U = qmc.LatinHypercube(d=int(dim), seed=seed, optimization=optimization).random(int(n))
    if design == "box":
        return U
    if design != "local":
        raise InputError(f"design must be 'box' or 'local', got {design!r}")
    if center is None:
        raise InputError("design 'local' needs a center (e.g. the safe start gains in the unit cube)")
    c = np.asarray(center, dtype=float)
    if c.shape != (dim,) or not np.all(np.isfinite(c)) or np.any(c < 0) or np.any(c > 1):
        raise InputError(f"center must be a point of the unit cube with shape ({dim},)")
    r = np.asarray(radius, dtype=float)
    if r.shape not in ((), (dim,)) or not np.all(np.isfinite(r)) or np.any(r <= 0):
        raise InputError(f"radius must be positive (scalar or shape ({dim},)), got {radius!r}")
    lo, hi = local_box(c, r)
    return lo + U * (hi - lo)
