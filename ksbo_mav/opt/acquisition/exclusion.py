"""Exclusion balls around bad trials: no certified query lands within ``radius`` of an unsafe or failed trial.

Why the balls grow (``growth`` > 1): on the planar suite the failures after the first one landed 0.05–0.075 from
an earlier failure — just outside a fixed 0.05 ball, where the posterior mean is high because the bistable gains
fly well from other starts (benchmarks/notes/plants.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ksbo_mav.opt.observations import Observations


def exclusion_radii(bad: np.ndarray, base: float, growth: float, cap: float) -> np.ndarray:
    """(k,) radii (unit cube) of the exclusion balls around the bad trials ``bad`` (k, d), in the order flown.

    Each ball starts at ``base``. When a later bad trial lands within twice the radius of an earlier ball, the
    bad region is evidently wider than that ball: the earlier ball grows ×``growth`` (at most ``cap``) and the new
    one starts at least as large. ``growth`` 1 keeps every ball at ``base`` (the paper method's fixed exclusion).
    """
    r = np.full(bad.shape[0], float(base))
    if growth <= 1.0:
        return r
    for i in range(1, bad.shape[0]):
        d = np.sqrt(((bad[:i] - bad[i]) ** 2).sum(-1))
        near = d < 2.0 * r[:i]
        if near.any():
            r[:i][near] = np.minimum(r[:i][near] * growth, cap)
            r[i] = max(r[i], float(r[:i][near].max()))
    return r


@dataclass(frozen=True)
class Exclusion:
    """Balls of ``radius`` (unit cube; 0 = none) around the bad trials, grown ×``growth`` up to ``cap``."""

    radius: float = 0.05
    growth: float = 1.0
    cap: float = 0.2

    def excluded(self, obs: Observations, Z: np.ndarray) -> np.ndarray:
        """(m,) bool: Z (m, d) inside the ball of a bad trial of ``obs``."""
        bad = obs.bad()
        if self.radius <= 0 or bad.shape[0] == 0:
            return np.zeros(Z.shape[0], dtype=bool)
        r = exclusion_radii(bad, self.radius, self.growth, self.cap)
        d2 = ((Z[:, None, :] - bad[None, :, :]) ** 2).sum(-1)
        return (d2 < r[None, :] ** 2).any(axis=1)

    def in_grown_ball(self, obs: Observations, Z: np.ndarray) -> np.ndarray:
        """(m,) bool: Z (m, d) inside a bad trial's ball when the balls grow (the adaptive optimiser): the fallback,
        the re-fly phase and the trust region's centre keep out of them. All False with fixed balls, where only
        certified candidates are excluded (the paper's method)."""
        if self.growth <= 1.0:
            return np.zeros(Z.shape[0], dtype=bool)
        return self.excluded(obs, Z)
