"""A search box that follows the evidence: it starts as the caller's box and grows towards wider limits when the
incumbent sits on one of its edges.

The caller's ``bounds`` are the first box (the unit cube, where every scale of the models is set: its GP
lengthscales, the trust region, the candidate clouds, so the first steps are exactly as small as without growth);
``limits`` are how far it may ever go (e.g. an autopilot's documented parameter ranges), in the same unit-cube
coordinates: lower limits ≤ 0, upper ≥ 1. After every trial the incumbent (the best completed safe trial by the
posterior mean: the trust region's centre) is checked; each edge it lies within ``tol`` of moves out by ``step``
(of the first box's width, 1), capped at the limit. Growing only opens room: every query still needs its
certificate (LCB ≥ p_min), so the optimiser steps past an old edge from certified points, as it stepped inside.
The box's state is a function of the trials, so a replayed run grows it at the same trials.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Growth:
    """One edge moved: dimension ``dim``, ``side`` "lower"/"upper", ``old`` → ``new`` (unit cube), after ``trial``
    trials of the run."""

    trial: int
    dim: int
    side: str
    old: float
    new: float


@dataclass
class GrowingBox:
    """Box ``lo ≤ z ≤ hi`` (unit cube) growing within ``limit_lo``/``limit_hi``; see the module docstring."""

    limit_lo: np.ndarray  # (d,) ≤ 0
    limit_hi: np.ndarray  # (d,) ≥ 1
    step: float = 0.5
    tol: float = 0.02
    lo: np.ndarray = field(init=False)
    hi: np.ndarray = field(init=False)
    history: list[Growth] = field(default_factory=list, init=False)

    def __post_init__(self) -> None:
        self.limit_lo = np.minimum(np.asarray(self.limit_lo, dtype=float), 0.0)
        self.limit_hi = np.maximum(np.asarray(self.limit_hi, dtype=float), 1.0)
        self.lo, self.hi = np.zeros_like(self.limit_lo), np.ones_like(self.limit_hi)

    def contains(self, Z: np.ndarray) -> np.ndarray:
        """(m,) bool: rows of Z (m, d) inside the box."""
        Z = np.atleast_2d(Z)
        return np.all((Z >= self.lo - 1e-12) & (Z <= self.hi + 1e-12), axis=1)

    def update(self, center: np.ndarray, trial: int, free: np.ndarray | None = None) -> list[Growth]:
        """Move out every edge of a ``free`` (d,) dimension that ``center`` (d,) lies within ``tol`` of; returns the
        moves (recorded in ``history``)."""
        c = np.asarray(center, dtype=float)
        free = np.ones(c.size, dtype=bool) if free is None else np.asarray(free, dtype=bool)
        moves = []
        for i in np.flatnonzero(free):
            if c[i] >= self.hi[i] - self.tol and self.hi[i] < self.limit_hi[i] - 1e-12:
                new = min(self.hi[i] + self.step, self.limit_hi[i])
                moves.append(Growth(trial, int(i), "upper", float(self.hi[i]), float(new)))
                self.hi[i] = new
            if c[i] <= self.lo[i] + self.tol and self.lo[i] > self.limit_lo[i] + 1e-12:
                new = max(self.lo[i] - self.step, self.limit_lo[i])
                moves.append(Growth(trial, int(i), "lower", float(self.lo[i]), float(new)))
                self.lo[i] = new
        self.history.extend(moves)
        return moves
