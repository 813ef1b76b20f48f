"""A smooth lead-in for periodic reference trajectories: a time warp that starts the pattern from rest.

A figure-8 whose reference is ``f(t)`` starts at full speed (3.5 m/s for the 3-D copter mission): a vehicle
hovering at the start point sees a velocity step, tilts hard for half a second (28° on the JSBSim ArduCopter, 38–44°
on the PX4 personality) and the monitor's tilt limit trips on that transient rather than on the gains' steady
tracking (benchmarks/notes/plants.md). Flying ``f(φ(t))`` instead, with the phase rate φ' rising from 0 to 1 over
``T`` seconds as the smoothstep 3u² − 2u³ (u = t/T), starts from rest with zero acceleration and joins the pattern
at t = T with continuous position, velocity and acceleration; after that the reference is the pattern delayed by
T/2. A lap scored after the lead-in is an ordinary lap of the pattern.

    φ(t) = T (u³ − u⁴/2)        for t < T          φ(t) = t − T/2   for t ≥ T
"""

from __future__ import annotations

import numpy as np


def lead_in_phase(t: np.ndarray | float, T: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Phase φ, rate φ' and its derivative φ'' at times ``t`` (any shape, s) for a lead-in of ``T`` s (0: none).

    The warped reference is then pos = f(φ), vel = f'(φ) φ', acc = f''(φ) φ'² + f'(φ) φ''. With a lead-in, times
    before 0 are clamped to 0 (the vehicle holds the start point, at rest); without one, φ = t everywhere.
    """
    t = np.asarray(t, dtype=float)
    if T <= 0:
        return t, np.ones_like(t), np.zeros_like(t)
    t = np.maximum(t, 0.0)
    u = np.minimum(t / T, 1.0)
    inside = t < T
    phase = np.where(inside, T * (u**3 - 0.5 * u**4), t - 0.5 * T)
    rate = np.where(inside, u * u * (3.0 - 2.0 * u), 1.0)
    rate_dot = np.where(inside, 6.0 * u * (1.0 - u) / T, 0.0)
    return phase, rate, rate_dot


__all__ = ["lead_in_phase"]
