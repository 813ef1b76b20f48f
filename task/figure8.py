"""Safe Control Gym's figure-8 reference in the x-z plane (envs/benchmark_env.py ``_figure8``)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Figure8:
    """x = s sin(wt), z = z0 + s sin(wt) cos(wt), w = 2 pi / period; analytic velocities and accelerations."""

    scale: float = 0.75
    period: float = 6.0
    z0: float = 1.0

    @property
    def omega(self) -> float:
        return 2.0 * math.pi / self.period

    def position(self, t: np.ndarray) -> np.ndarray:
        """Reference position, shape (*t.shape, 2) with columns (x, z) in metres (z up)."""
        t = np.asarray(t, dtype=float)
        w = self.omega
        s = np.sin(w * t)
        return np.stack([self.scale * s, self.z0 + self.scale * s * np.cos(w * t)], axis=-1)

    def velocity(self, t: np.ndarray) -> np.ndarray:
        """Reference velocity (*t.shape, 2): (s w cos wt, s w cos 2wt)."""
        t = np.asarray(t, dtype=float)
        w = self.omega
        return np.stack([self.scale * w * np.cos(w * t), self.scale * w * np.cos(2.0 * w * t)], axis=-1)

    def acceleration(self, t: np.ndarray) -> np.ndarray:
        """Reference acceleration (*t.shape, 2): (-s w^2 sin wt, -2 s w^2 sin 2wt)."""
        t = np.asarray(t, dtype=float)
        w = self.omega
        return np.stack(
            [-self.scale * w * w * np.sin(w * t), -2.0 * self.scale * w * w * np.sin(2.0 * w * t)], axis=-1
        )

    def state(self, t: np.ndarray) -> np.ndarray:
        """Full 6-state reference [x, vx, z, vz, theta, theta_dot] (*t.shape, 6); pitch references are 0."""
        p, v = self.position(t), self.velocity(t)
        zeros = np.zeros(p.shape[:-1])
        return np.stack([p[..., 0], v[..., 0], p[..., 1], v[..., 1], zeros, zeros], axis=-1)
