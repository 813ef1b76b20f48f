"""Trust region of the adaptive safe BO (SCBO/TuRBO-style): a box around the incumbent whose size
follows the outcomes of the trials flown in it.

State machine: a completed safe trial that becomes the incumbent (the best by the posterior mean, which the
caller decides) is a *success*; every ``success_tol`` successes grow the half-width ×``grow`` (up to
``r_max``); an aborted or crashed trial shrinks it ×``shrink`` (down to ``r_min``) and resets the success count;
a completed trial that does not become the incumbent leaves it unchanged. Per-dimension half-widths are
``radius × w_i`` with ``w`` the safety lengthscales normalised to geometric mean 1, so the box is longer along the
dimensions the safety model finds smooth.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ksbo_mav.opt.evaluation import Outcome


@dataclass
class TrustRegion:
    """Box ``|z − center| ≤ radius · weights`` (unit cube); see the module docstring for the updates."""

    radius: float = 0.1
    r_min: float = 0.02
    r_max: float = 0.5
    grow: float = 2.0
    shrink: float = 0.5
    success_tol: int = 2
    center: np.ndarray | None = None  # (d,)
    weights: np.ndarray | None = None  # (d,) positive, geometric mean 1
    successes: int = field(default=0, init=False)
    history: list[tuple[str, float]] = field(default_factory=list, init=False)  # (event, radius after)

    def update(self, outcome: Outcome, improved: bool) -> None:
        """Advance the state machine after one trial."""
        if outcome is not Outcome.COMPLETE:
            self.radius = max(self.radius * self.shrink, self.r_min)
            self.successes = 0
            self.history.append(("shrink", self.radius))
            return
        if not improved:
            return
        self.successes += 1
        if self.successes >= self.success_tol:
            self.radius = min(self.radius * self.grow, self.r_max)
            self.successes = 0
            self.history.append(("grow", self.radius))

    def set_weights(self, lengthscales: np.ndarray) -> None:
        """Per-dimension shape from (d,) lengthscales (normalised to geometric mean 1, clipped to [0.25, 4])."""
        ls = np.asarray(lengthscales, dtype=float)
        w = ls / np.exp(np.mean(np.log(ls)))
        self.weights = np.clip(w, 0.25, 4.0)

    def half_widths(self, dim: int) -> np.ndarray:
        """(dim,) half-widths of the box."""
        w = np.ones(dim) if self.weights is None else self.weights
        return self.radius * w

    def contains(self, Z: np.ndarray) -> np.ndarray:
        """(m,) bool: rows of Z (m, d) inside the box (everything when no centre is set)."""
        Z = np.atleast_2d(Z)
        if self.center is None:
            return np.ones(Z.shape[0], dtype=bool)
        return np.all(np.abs(Z - self.center) <= self.half_widths(Z.shape[1]) + 1e-12, axis=1)
