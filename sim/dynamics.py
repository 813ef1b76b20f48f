"""Planar quadrotor rigid-body dynamics (the paper's model), integrated like pyBullet in SCG.

State s = [x, vx, z, vz, theta, theta_dot] (z up, theta = pitch, positive pitch accelerates +x):

    x'' = sin(theta) (T1 + T2) / m,   z'' = cos(theta) (T1 + T2) / m - g,   theta'' = (T2 - T1) d / Iyy

Thrusts are held constant over one control period (zero-order hold) while the physics takes ``n_sub``
semi-implicit Euler sub-steps (velocity updated before position, as in Bullet).
"""

from __future__ import annotations

import numpy as np

from ksbo_sim.constants import QuadConstants


def integrate(state: np.ndarray, thrusts: np.ndarray, c: QuadConstants, dt: float, n_sub: int,
              accel: np.ndarray | None = None) -> np.ndarray:
    """Advance a batch of states by one control period ``dt`` with ``n_sub`` semi-implicit Euler sub-steps.

    Exactly the sub-step recursion, summed in closed form: pitch follows a quadratic in the sub-step index,
    so the n_sub pitch values come from one broadcast, and the translational sums are two small products.
    This replaces n_sub sequential numpy passes by a handful of (B, n_sub) operations.

    Args:
        state: (B, 6) states at the start of the period.
        thrusts: (B, 2) pair thrusts T1, T2 in newtons, held for the whole period.
        accel: optional (B, 2) external acceleration (x, z) in m/s², held for the period (wind gusts).
    Returns:
        (B, 6) states at the end of the period.
    """
    h = dt / n_sub
    x, vx, z, vz, th, om = state.T
    total = (thrusts[:, 0] + thrusts[:, 1]) / c.mass
    alpha = (thrusts[:, 1] - thrusts[:, 0]) * (c.moment_arm / c.iyy)
    j = np.arange(n_sub, dtype=float)
    # theta_j = theta_0 + j h omega_0 + h^2 alpha j (j + 1) / 2 : pitch at the start of sub-step j.
    th_j = th[:, None] + (h * j)[None, :] * om[:, None] + (h * h * j * (j + 1) / 2.0)[None, :] * alpha[:, None]
    # Row-wise sums rather than a BLAS product: BLAS may block differently for different batch sizes,
    # and this system is chaotic for chattering gains, so each row must not depend on the batch around it.
    w = (n_sub - j)[None, :]
    sin_j, cos_j = np.sin(th_j), np.cos(th_j)
    s_sums = (sin_j.sum(axis=1), (sin_j * w).sum(axis=1))
    c_sums = (cos_j.sum(axis=1), (cos_j * w).sum(axis=1))
    n = float(n_sub)
    out = np.empty_like(state)
    out[:, 1] = vx + h * total * s_sums[0]
    out[:, 0] = x + n * h * vx + h * h * total * s_sums[1]
    out[:, 3] = vz + h * (total * c_sums[0] - n * c.g)
    out[:, 2] = z + n * h * vz + h * h * (total * c_sums[1] - c.g * n * (n + 1) / 2.0)
    out[:, 5] = om + n * h * alpha
    out[:, 4] = th + n * h * om + h * h * alpha * n * (n + 1) / 2.0
    if accel is not None:
        out[:, 1] += n * h * accel[:, 0]
        out[:, 3] += n * h * accel[:, 1]
        out[:, 0] += h * h * accel[:, 0] * n * (n + 1) / 2.0
        out[:, 2] += h * h * accel[:, 1] * n * (n + 1) / 2.0
    return out


def integrate_stepwise(state: np.ndarray, thrusts: np.ndarray, c: QuadConstants, dt: float, n_sub: int) -> np.ndarray:
    """The same period integrated one sub-step at a time (reference for tests; slower)."""
    h = dt / n_sub
    s = np.array(state, dtype=float, copy=True)
    total = (thrusts[:, 0] + thrusts[:, 1]) / c.mass
    alpha = (thrusts[:, 1] - thrusts[:, 0]) * (c.moment_arm / c.iyy)
    for _ in range(n_sub):
        ax = np.sin(s[:, 4]) * total
        az = np.cos(s[:, 4]) * total - c.g
        s[:, 1] += h * ax
        s[:, 3] += h * az
        s[:, 5] += h * alpha
        s[:, 0] += h * s[:, 1]
        s[:, 2] += h * s[:, 3]
        s[:, 4] += h * s[:, 5]
    return s
