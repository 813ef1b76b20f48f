"""Attitude and rate loops plus motor mixer, modelled on ArduCopter's AC_AttitudeControl_Multi / AP_MotorsMatrix.

Fixed inner loops (the tuner never touches them): target lean angles are shaped with a first-order time
constant ``input_tc`` and an angular-acceleration limit (ArduCopter ATC_INPUT_TC, ATC_ACCEL_*_MAX, rate
feed-forward on), the angle P loop adds a body-rate correction, and a rate PID (ArduPilot AC_PID: target
filter FLTT, derivative filter FLTD, integrator limit IMAX) gives normalised roll/pitch/yaw outputs. The
mixer turns collective + outputs into per-motor thrust with roll/pitch priority, as AP_MotorsMatrix does;
an output of 1 moves each motor by 0.5 * thrust_max (ArduPilot normalises X-frame factors to +-0.5).
Scalars are plain floats: this runs every 2 ms physics step and numpy per-call overhead would dominate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ksbo_sim.copter3d.backend import Airframe

#: Mixer factors (roll, pitch, yaw) per motor in backend.MOTORS order FR, AL, FL, AR. Signs verified against
#: the JSBSim moments: extra thrust on FR rolls left (-), pitches up (+) and yaws right (+, prop sense +1).
MIX = ((-0.5, 0.5, 0.5), (0.5, -0.5, 0.5), (0.5, 0.5, -0.5), (-0.5, -0.5, -0.5))


@dataclass
class AttitudeGains:
    """Inner-loop gains (ArduCopter ATC_* names in comments; PX4 MC_* map onto the same fields).

    Units: angle P in (rad/s)/rad; rate P/I/D in normalised output per rad/s (per rad, per rad/s^2);
    filters in Hz; accel limits rad/s^2; input_tc s.
    """

    ang_rp_p: float = 4.5  # ATC_ANG_RLL_P = ATC_ANG_PIT_P
    ang_y_p: float = 4.5  # ATC_ANG_YAW_P
    rat_rp_p: float = 0.135  # ATC_RAT_RLL_P / _PIT_P
    rat_rp_i: float = 0.135
    rat_rp_d: float = 0.0036
    rat_rp_imax: float = 0.5
    rat_y_p: float = 0.18  # ATC_RAT_YAW_P
    rat_y_i: float = 0.018
    rat_fltt_hz: float = 20.0
    rat_fltd_hz: float = 20.0
    input_tc: float = 0.15  # ATC_INPUT_TC
    accel_rp_max: float = math.radians(1100.0)  # ATC_ACCEL_R_MAX / _P_MAX 110000 cdeg/s^2
    accel_y_max: float = math.radians(270.0)  # ATC_ACCEL_Y_MAX 27000 cdeg/s^2


def _alpha(hz: float, dt: float) -> float:
    """First-order low-pass coefficient (ArduPilot LowPassFilter): 1 = no filtering."""
    if hz <= 0.0:
        return 1.0
    rc = 1.0 / (2.0 * math.pi * hz)
    return dt / (dt + rc)


class AttitudeController:
    """Lean-angle and yaw targets -> rate PIDs -> motor thrusts. All angles rad, body rates rad/s."""

    def __init__(self, airframe: Airframe, dt: float, gains: AttitudeGains | None = None) -> None:
        self.af = airframe
        self.dt = dt
        self.g = gains or AttitudeGains()
        self.reset(0.0)

    def reset(self, yaw: float) -> None:
        """Level targets at heading ``yaw``; integrators and filters zeroed."""
        self.att_t = [0.0, 0.0, yaw]  # shaped attitude target (roll, pitch, yaw)
        self.rate_t = [0.0, 0.0, 0.0]  # shaped Euler-rate target (feed-forward)
        self.r_tgt = [0.0, 0.0, 0.0]  # filtered rate-PID target
        self.r_err = [0.0, 0.0, 0.0]
        self.r_der = [0.0, 0.0, 0.0]
        self.r_int = [0.0, 0.0, 0.0]
        self.out = [0.0, 0.0, 0.0]

    def update(self, roll_d: float, pitch_d: float, yaw_d: float, rpy: np.ndarray, rates: np.ndarray,
               collective: float) -> np.ndarray:
        """One inner-loop step. Returns per-motor thrust (4,) in N.

        Args:
            roll_d, pitch_d, yaw_d: desired attitude (rad) from the position controller.
            rpy: measured roll, pitch, yaw (rad); rates: body p, q, r (rad/s).
            collective: thrust-linearised throttle 0..1 (fraction of 4 * thrust_max), tilt-compensated.
        """
        g, dt = self.g, self.dt
        # Input shaping: Euler-rate target towards (desired - target)/tc, changed at most accel_max * dt.
        desired = (roll_d, pitch_d, yaw_d)
        amax = (g.accel_rp_max, g.accel_rp_max, g.accel_y_max)
        for i in range(3):
            err = desired[i] - self.att_t[i]
            if i == 2:
                err = (err + math.pi) % (2.0 * math.pi) - math.pi
            want = err / g.input_tc
            step = amax[i] * dt
            self.rate_t[i] += min(max(want - self.rate_t[i], -step), step)
            self.att_t[i] += self.rate_t[i] * dt
        phi, theta, psi = float(rpy[0]), float(rpy[1]), float(rpy[2])
        # Angle P on the shaped target plus its rate as feed-forward (Euler rates).
        e_r = self.att_t[0] - phi
        e_p = self.att_t[1] - theta
        e_y = (self.att_t[2] - psi + math.pi) % (2.0 * math.pi) - math.pi
        dphi = self.rate_t[0] + g.ang_rp_p * e_r
        dtheta = self.rate_t[1] + g.ang_rp_p * e_p
        dpsi = self.rate_t[2] + g.ang_y_p * e_y
        # Euler rates -> body rates (the loops run in body axes, as ArduPilot's do).
        sphi, cphi = math.sin(phi), math.cos(phi)
        sth, cth = math.sin(theta), math.cos(theta)
        body_t = (dphi - sth * dpsi, cphi * dtheta + sphi * cth * dpsi, -sphi * dtheta + cphi * cth * dpsi)
        kp = (g.rat_rp_p, g.rat_rp_p, g.rat_y_p)
        ki = (g.rat_rp_i, g.rat_rp_i, g.rat_y_i)
        kd = (g.rat_rp_d, g.rat_rp_d, 0.0)
        at = _alpha(g.rat_fltt_hz, dt)
        ad = _alpha(g.rat_fltd_hz, dt)
        for i in range(3):
            self.r_tgt[i] += at * (body_t[i] - self.r_tgt[i])
            err = self.r_tgt[i] - float(rates[i])
            der = (err - self.r_err[i]) / dt
            self.r_err[i] = err
            self.r_der[i] += ad * (der - self.r_der[i])
            # Integrator with IMAX clamp (anti-windup as AC_PID: freeze when the output saturated).
            self.r_int[i] = min(max(self.r_int[i] + ki[i] * err * dt, -g.rat_rp_imax), g.rat_rp_imax)
            self.out[i] = kp[i] * err + self.r_int[i] + kd[i] * self.r_der[i]
        return self.mix(collective, self.out[0], self.out[1], self.out[2])

    def mix(self, collective: float, roll: float, pitch: float, yaw: float) -> np.ndarray:
        """Normalised outputs -> per-motor thrust (N), roll/pitch first, then throttle, then yaw headroom."""
        roll = min(max(roll, -1.0), 1.0)
        pitch = min(max(pitch, -1.0), 1.0)
        rp = [m[0] * roll + m[1] * pitch for m in MIX]
        hi, lo = max(rp), min(rp)
        # Shift the collective so roll/pitch fit in 0..1 (attitude has priority over altitude, as in AP).
        thr = min(max(collective, -lo), 1.0 - hi) if hi - lo <= 1.0 else 0.5 - 0.5 * (hi + lo)
        # Yaw gets what headroom is left.
        room = min(min(1.0 - (thr + v) for v in rp), min(thr + v for v in rp))
        yaw = min(max(yaw, -2.0 * max(room, 0.0)), 2.0 * max(room, 0.0))
        frac = [min(max(thr + rp[i] + MIX[i][2] * yaw, 0.0), 1.0) for i in range(4)]
        return np.array(frac) * self.af.thrust_max
