"""2-D reduction of Safe Control Gym's PID (controllers/pid/pid.py), vectorised over a batch of gain vectors.

Gains per row: [Px, Ix, Dx, Pz, Iz, Dz, Ptheta, Itheta, Dtheta]. The position PID gives a desired force
vector; its projection on the body axis is the collective thrust and its direction the pitch target; the
attitude PID gives a torque in PWM units that the mixer splits between the two motor pairs.

SCG's mixer clips each motor to the PWM range, so when the position loop asks for little or no thrust both motors
sit at the minimum and the torque is lost: a vehicle caught pitching keeps its pitch rate. Rows flagged in
``attitude_priority`` (the in-process monitor's backup) shift the collective instead so that the torque survives,
as ArduPilot's mixer does (attitude before throttle, ``ATC_THR_MIX_*``) and PX4's with airmode.
"""

from __future__ import annotations

import numpy as np

from ksbo_sim.constants import QuadConstants

GAIN_LABELS = ("Px", "Ix", "Dx", "Pz", "Iz", "Dz", "Ptheta", "Itheta", "Dtheta")


class PlanarPID:
    """Batched controller with its integrators and previous pitch. Call :meth:`reset` before an episode."""

    def __init__(self, gains: np.ndarray, constants: QuadConstants, dt: float) -> None:
        gains = np.atleast_2d(np.asarray(gains, dtype=float))
        if gains.shape[-1] != 9:
            raise ValueError(f"expected 9 gains per row, got shape {gains.shape}")
        self.gains = gains
        self.c = constants
        self.dt = dt
        self.int_pos = np.zeros((gains.shape[0], 2))
        self.int_pitch = np.zeros(gains.shape[0])
        self.prev_pitch = np.zeros(gains.shape[0])
        #: (B,) rows whose mixer keeps torque authority (see :meth:`__call__`); the backup of a tripped flight.
        self.attitude_priority = np.zeros(gains.shape[0], dtype=bool)

    def reset(self, pitch: np.ndarray | None = None) -> None:
        """Zero the integrators; the previous pitch starts at the current pitch (SCG starts it at 0)."""
        self.int_pos[:] = 0.0
        self.int_pitch[:] = 0.0
        self.prev_pitch[:] = 0.0 if pitch is None else pitch

    def select(self, idx: np.ndarray) -> None:
        """Keep only the rows ``idx`` (used when crashed episodes leave a batch)."""
        self.gains = self.gains[idx]
        self.int_pos = self.int_pos[idx]
        self.int_pitch = self.int_pitch[idx]
        self.prev_pitch = self.prev_pitch[idx]
        self.attitude_priority = self.attitude_priority[idx]

    def __call__(self, state: np.ndarray, ref_pos: np.ndarray, ref_vel: np.ndarray) -> np.ndarray:
        """One control step.

        Args:
            state: (B, 6) [x, vx, z, vz, theta, theta_dot].
            ref_pos, ref_vel: (2,) or (B, 2) reference (x, z) position and velocity.
        Returns:
            (B, 2) pair thrusts T1, T2 in newtons (already limited by the PWM range).
        """
        c, dt, k = self.c, self.dt, self.gains
        theta = state[:, 4]
        e = np.asarray(ref_pos) - state[:, (0, 2)]
        self.int_pos += e * dt
        _clip(self.int_pos[:, 0], c.pos_integral_limit_x)
        _clip(self.int_pos[:, 1], c.pos_integral_limit_z)
        dv = np.asarray(ref_vel) - state[:, (1, 3)]
        fx = k[:, 0] * e[:, 0] + k[:, 1] * self.int_pos[:, 0] + k[:, 2] * dv[:, 0]
        fz = k[:, 3] * e[:, 1] + k[:, 4] * self.int_pos[:, 1] + k[:, 5] * dv[:, 1] + c.mass * c.g
        thrust = np.maximum(0.0, fx * np.sin(theta) + fz * np.cos(theta))
        pwm_thrust = (np.sqrt(thrust / (4.0 * c.kf)) - c.pwm2rpm_const) / c.pwm2rpm_scale
        # With fz <= 0 SCG's target attitude is flipped (roll = pi) and its pitch error is exactly 0.
        e_pitch = np.where(fz > 0.0, 2.0 * np.sin(theta - np.arctan2(fx, fz)), 0.0)
        self.int_pitch -= e_pitch * dt
        _clip(self.int_pitch, c.pitch_integral_limit)
        torque = -k[:, 6] * e_pitch - k[:, 8] * (theta - self.prev_pitch) / dt + k[:, 7] * self.int_pitch
        _clip(torque, c.max_torque_pwm)
        self.prev_pitch = theta.copy()
        m = self.attitude_priority
        if m.any():  # attitude priority: shift the collective so the torque is not lost to the PWM limits
            half = 0.5 * np.abs(torque[m])
            pwm_thrust[m] = np.minimum(np.maximum(pwm_thrust[m], c.pwm_min + half), c.pwm_max - half)
        pwm = np.stack([pwm_thrust - 0.5 * torque, pwm_thrust + 0.5 * torque], axis=1)
        np.minimum(np.maximum(pwm, c.pwm_min, out=pwm), c.pwm_max, out=pwm)
        rpm = c.pwm2rpm_scale * pwm + c.pwm2rpm_const
        return 2.0 * c.kf * rpm * rpm


def _clip(a: np.ndarray, limit: float) -> None:
    """In-place clip to [-limit, limit]; same result as np.clip (NaN propagates) at a fraction of its call cost."""
    np.minimum(np.maximum(a, -limit, out=a), limit, out=a)
