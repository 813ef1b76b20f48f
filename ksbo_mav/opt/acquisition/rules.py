"""Acquisition rules of the safe optimiser as small objects (BoTorch style).

Each rule is called on candidates ``Z`` (m, d) and returns ``(score (m,), feasible (m,) bool)``; the optimiser
scores its candidate set with it, refines the best few under the same rule (``candidates.refine`` only accepts
feasible moves) and queries the best. A rule reads the posterior through the :class:`Posterior` protocol, so it
can be unit-tested on any object with ``bounds``/``feasible``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np


class Posterior(Protocol):
    """What a rule needs from the optimiser."""

    def bounds(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Posterior mean, std, safety LCB and acquisition UCB at Z (m, d): four (m,) arrays."""

    def feasible(self, Z: np.ndarray, lcb: np.ndarray) -> np.ndarray:
        """(m,) bool: may Z be queried (certified, or covered by the backup)?"""


class Acquisition(Protocol):
    """``rule(Z (m, d)) -> (score (m,), feasible (m,) bool)``; ``kind`` labels the proposals it makes."""

    kind: str

    def __call__(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...


@dataclass
class PosteriorMean:
    """Exploitation: ``μ − exploit_beta·σ`` over the feasible set (``exploit_beta = 0``: the posterior mean)."""

    post: Posterior
    exploit_beta: float = 0.0
    kind: str = "exploit"

    def __call__(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        m, s, lo, _ = self.post.bounds(Z)
        return m - self.exploit_beta * s, self.post.feasible(Z, lo)


@dataclass
class SafeUCB:
    """The safe UCB maximiser: ``μ + β_ucb σ`` over the feasible set."""

    post: Posterior
    kind: str = "ucb"

    def __call__(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        _, _, lo, up = self.post.bounds(Z)
        return up, self.post.feasible(Z, lo)


@dataclass
class WidestFeasible:
    """Pure exploration: the largest posterior std over the feasible set."""

    post: Posterior
    kind: str = "expand"

    def __call__(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        _, s, lo, _ = self.post.bounds(Z)
        return s, self.post.feasible(Z, lo)


@dataclass
class BoundaryExpansion:
    """SafeCtrlBO's expansion rule: the widest feasible point, started from the candidates in the boundary band
    ``LCB − p_min ≤ band`` (:meth:`pool`; all feasible candidates if the band is empty)."""

    post: Posterior
    p_min: float
    band: float
    kind: str = "expand"

    def __call__(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        _, s, lo, _ = self.post.bounds(Z)
        return s, self.post.feasible(Z, lo)

    def pool(self, Z: np.ndarray) -> np.ndarray:
        """(m,) bool: candidates the refinement may start from."""
        _, _, lo, _ = self.post.bounds(Z)
        ok = self.post.feasible(Z, lo)
        boundary = ok & (lo - self.p_min <= self.band)
        return boundary if boundary.any() else ok


@dataclass
class SafeOptRule:
    """SafeOpt's rule: the widest interval among the plausible maximisers ``{UCB ≥ best_lcb}`` and the boundary
    points ``{LCB − p_min ≤ band}`` of the feasible set."""

    post: Posterior
    p_min: float
    band: float
    best_lcb: float
    kind: str = "safeopt"

    def __call__(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        _, s, lo, up = self.post.bounds(Z)
        pool = self.post.feasible(Z, lo) & ((up >= self.best_lcb) | (lo - self.p_min <= self.band))
        return np.where(pool, s, -np.inf), pool
