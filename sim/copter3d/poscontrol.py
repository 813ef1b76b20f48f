"""Position controller modelled on ArduCopter's AC_PosControl (4.7, SI units; PX4 variant for the Z axis).

NE: position P -> velocity target (+ velocity feed-forward) -> velocity PID (error filter FLTE, derivative
filter FLTD, IMAX, velocity FF) -> acceleration target (+ acceleration feed-forward) -> lean angles
``pitch = atan(-a_fwd / g)``, ``roll = atan(a_right cos(pitch) / g)`` limited to ``angle_max``.
D: position P -> velocity P (+ FF) -> acceleration target (+ FF) -> acceleration PID on the measured vertical
acceleration -> throttle around the hover throttle (the vehicle divides it by cos(tilt): angle boost).
PX4 style (``z_px4=True``): the vertical velocity loop is a PID (D on the velocity error) giving the acceleration
target and thrust is
``hover * (1 - a_D / g)`` with no acceleration feedback (mc_pos_control's two stages).
There is no NE position I term, as in ArduCopter. Gains are the canonical internal vector
:class:`PosGains` (ArduPilot 4.7+ SI names); ``params.py`` maps autopilot parameters onto it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from ksbo_sim.copter3d.backend import G0


@dataclass
class PosGains:
    """Canonical position-loop gains (units SI; names after ArduPilot's PSC_NE_* / PSC_D_* generation)."""

    ne_pos_p: float = 1.0  # (m/s)/m
    ne_vel_p: float = 2.0  # (m/s^2)/(m/s)
    ne_vel_i: float = 1.0  # (m/s^2)/m
    ne_vel_d: float = 0.25  # (m/s^2)/(m/s^2)
    ne_vel_imax: float = 10.0  # m/s^2
    ne_vel_ff: float = 0.0
    ne_vel_flte: float = 5.0  # Hz
    ne_vel_fltd: float = 5.0  # Hz
    d_pos_p: float = 1.0
    d_vel_p: float = 5.0
    d_vel_i: float = 0.0
    d_vel_d: float = 0.0
    d_vel_imax: float = 10.0  # m/s^2 (PX4 path only)
    d_acc_p: float = 0.05  # throttle per m/s^2
    d_acc_i: float = 0.1  # throttle per m/s
    d_acc_d: float = 0.0
    d_acc_imax: float = 0.8  # throttle
    d_acc_flte: float = 20.0  # Hz
    angle_max_deg: float = 30.0
    vel_max_ne: float = 10.0  # m/s, position-loop velocity limit (WPNAV_SPEED / MPC_XY_VEL_MAX)
    vel_max_d: float = 2.5  # m/s (WPNAV_SPEED_UP 250 cm/s)

    @classmethod
    def names(cls) -> list[str]:
        return [f.name for f in fields(cls)]


def _alpha(hz: float, dt: float) -> float:
    if hz <= 0.0:
        return 1.0
    return dt / (dt + 1.0 / (2.0 * math.pi * hz))


class PositionController:
    """Stateful NE + D controller. Positions/velocities/accelerations NED (m, m/s, m/s^2)."""

    def __init__(self, dt: float, hover_throttle: float, gains: PosGains | None = None, z_px4: bool = False) -> None:
        self.dt = dt
        self.hover = hover_throttle
        self.g = gains or PosGains()
        self.z_px4 = z_px4
        self.reset()

    def reset(self) -> None:
        """Zero integrators and filters (called on reset and when a flight starts)."""
        self.ve_f = [0.0, 0.0]  # filtered NE velocity error
        self.ve_prev = [0.0, 0.0]
        self.ve_der = [0.0, 0.0]
        self.ve_int = [0.0, 0.0]
        self.vz_int = 0.0
        self.az_err_f = 0.0
        self.az_int = 0.0
        self.vd_prev: float | None = None
        self.az_err_prev = 0.0
        self.ez_prev = 0.0
        self.first = True

    def update(self, pos: list[float], vel: list[float], yaw: float, pos_t: list[float], vel_t: list[float],
               acc_t: list[float]) -> tuple[float, float, float]:
        """One step. Targets are already dead-reckoned to now. Returns (roll rad, pitch rad, throttle before angle
        boost, fraction of full thrust)."""
        g, dt = self.g, self.dt
        # --- NE: position P -> velocity target, limited in magnitude like AC_PosControl's limit_vector_length.
        vx = g.ne_pos_p * (pos_t[0] - pos[0])
        vy = g.ne_pos_p * (pos_t[1] - pos[1])
        n = math.hypot(vx, vy)
        if n > g.vel_max_ne:
            vx, vy = vx * g.vel_max_ne / n, vy * g.vel_max_ne / n
        vt = (vx + vel_t[0], vy + vel_t[1])
        a_e = _alpha(g.ne_vel_flte, dt)
        a_d = _alpha(g.ne_vel_fltd, dt)
        acc = [0.0, 0.0]
        for i in range(2):
            err = vt[i] - vel[i]
            if self.first:
                self.ve_f[i] = err
                self.ve_prev[i] = err
            self.ve_f[i] += a_e * (err - self.ve_f[i])
            der = (self.ve_f[i] - self.ve_prev[i]) / dt
            self.ve_prev[i] = self.ve_f[i]
            self.ve_der[i] += a_d * (der - self.ve_der[i])
            self.ve_int[i] += g.ne_vel_i * self.ve_f[i] * dt
            acc[i] = g.ne_vel_p * self.ve_f[i] + g.ne_vel_d * self.ve_der[i] + g.ne_vel_ff * vt[i] + acc_t[i]
        # Integrator limited as a vector (AC_PID_2D).
        ni = math.hypot(self.ve_int[0], self.ve_int[1])
        if ni > g.ne_vel_imax:
            self.ve_int = [v * g.ne_vel_imax / ni for v in self.ve_int]
        acc = [acc[0] + self.ve_int[0], acc[1] + self.ve_int[1]]
        # Lean-angle limit as an acceleration limit (g tan(angle_max)), applied to the vector.
        amax = G0 * math.tan(math.radians(g.angle_max_deg))
        na = math.hypot(acc[0], acc[1])
        if na > amax:
            acc = [acc[0] * amax / na, acc[1] * amax / na]
        # Earth -> heading frame, then lean angles (AC_PosControl::accel_to_lean_angles).
        cy, sy = math.cos(yaw), math.sin(yaw)
        a_fwd = acc[0] * cy + acc[1] * sy
        a_rgt = -acc[0] * sy + acc[1] * cy
        pitch = math.atan(-a_fwd / G0)
        roll = math.atan(a_rgt * math.cos(pitch) / G0)
        # --- D axis.
        vzt = g.d_pos_p * (pos_t[2] - pos[2])
        vzt = min(max(vzt, -g.vel_max_d), g.vel_max_d) + vel_t[2]
        ez = vzt - vel[2]
        # Measured vertical acceleration (down) from the velocity difference: the sim has no accelerometer noise.
        az_meas = 0.0 if self.vd_prev is None else (vel[2] - self.vd_prev) / dt
        self.vd_prev = vel[2]
        if self.z_px4:
            self.vz_int = min(max(self.vz_int + g.d_vel_i * ez * dt, -g.d_vel_imax), g.d_vel_imax)
            dez = 0.0 if self.first else (ez - self.ez_prev) / dt
            self.ez_prev = ez
            az_t = g.d_vel_p * ez + self.vz_int + g.d_vel_d * dez + acc_t[2]
            thr = self.hover * (1.0 - az_t / G0)
        else:
            az_t = g.d_vel_p * ez + acc_t[2]
            # ArduPilot's accel PID acts on "up" acceleration error; throttle rises when more up-accel is wanted.
            err = -(az_t - az_meas)
            if self.first:
                self.az_err_f = err
            self.az_err_f += _alpha(g.d_acc_flte, dt) * (err - self.az_err_f)
            self.az_int = min(max(self.az_int + g.d_acc_i * self.az_err_f * dt, -g.d_acc_imax), g.d_acc_imax)
            d_err = 0.0 if self.first else (self.az_err_f - self.az_err_prev) / dt
            self.az_err_prev = self.az_err_f
            thr = self.hover + g.d_acc_p * self.az_err_f + self.az_int + g.d_acc_d * d_err
        self.first = False
        # The caller divides by cos(tilt) of the measured attitude (ArduPilot's angle boost).
        return roll, pitch, thr
