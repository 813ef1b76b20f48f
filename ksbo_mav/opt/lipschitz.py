"""LoSBO's safe set: certified by a Lipschitz bound on the flown data instead of the GP's lower bound.

Fiedler, Menn, Kreisköther and Trimpe ("On safety in safe Bayesian optimization", TMLR 2024) note that the GP
bound μ − βσ is only as safe as the GP is well specified, and propose Lipschitz-only safe BO (LoSBO): with a
Lipschitz constant L of the objective and a bound E on the noise, gains x are safe if some flown gains x_i give
``y_i − E − L‖x − x_i‖ ≥ p_min``; the GP only chooses where to go inside that set. Issue 13 names it among the
designs to try (``lipschitz``, an option; BENCHMARKS.md, issue 13, item AN).

The bound is taken per distinct flown point over *all* its flights, failed ones included (their recorded value is
below p_min), so a point that completed once and failed once certifies nothing: bistable gains break the bounded
noise assumption, and the smallest value is the only one the assumption still covers.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial.distance import cdist

if TYPE_CHECKING:
    from ksbo_mav.opt.safe_bo import SafeBO


def flown_floor(X: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct flown points (k, d) of X (n, d) and the smallest value (k,) of y (n,) flown at each."""
    pts, inverse = np.unique(X, axis=0, return_inverse=True)
    low = np.full(pts.shape[0], np.inf)
    np.minimum.at(low, inverse.reshape(-1), y)
    return pts, low


def lipschitz_lcb(X: np.ndarray, y: np.ndarray, Z: np.ndarray, L: float, noise: float) -> np.ndarray:
    """(m,) LoSBO lower bound at Z (m, d): ``max_i (y_i − noise − L‖Z − x_i‖)`` over the distinct flown points
    x_i of X (n, d) with y_i their smallest flown value (:func:`flown_floor`); −inf where nothing was flown."""
    Z = np.atleast_2d(np.asarray(Z, dtype=float))
    if np.asarray(y).size == 0:
        return np.full(Z.shape[0], -np.inf)
    pts, low = flown_floor(np.asarray(X, dtype=float), np.asarray(y, dtype=float))
    return np.max(low[None, :] - noise - L * cdist(Z, pts), axis=1)


def lower_bound(bo: "SafeBO", Z: np.ndarray) -> np.ndarray:
    """(m,) the state machine's LoSBO bound at Z (m, d) from every trial of the run (prior included)."""
    c = bo.config
    return lipschitz_lcb(bo.X, bo.y, Z, float(c.lipschitz), c.lipschitz_noise)
