"""Attitude and rate loops plus motor mixer, modelled on ArduCopter's AC_AttitudeControl_Multi / AP_MotorsMatrix.

Fixed inner loops (the tuner never touches them): target lean angles are shaped with a first-order time
constant ``input_tc`` through ArduPilot's sqrt controller and an angular-acceleration limit (ArduCopter
ATC_INPUT_TC, ATC_ACCEL_*_MAX, rate
feed-forward on), the angle P loop adds a body-rate correction, and a rate PID (ArduPilot AC_PID: target
filter FLTT, derivative filter FLTD, integrator limit IMAX) gives normalised roll/pitch/yaw outputs. The
mixer turns collective + outputs into per-motor thrust with roll/pitch priority, as AP_MotorsMatrix does;
an output of 1 moves each motor by 0.5 * thrust_max (ArduPilot normalises X-frame factors to +-0.5).
Scalars are plain floats: this runs every physics step (2.5 ms) and numpy per-call overhead would dominate.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ksbo_sim.copter3d.backend import Airframe

#: Mixer factors (roll, pitch, yaw) per motor in backend.MOTORS order FR, AL, FL, AR. Signs verified against
#: the JSBSim moments: extra thrust on FR rolls left (-), pitches up (+) and yaws right (+, prop sense +1).
MIX = ((-0.5, 0.5, 0.5), (0.5, -0.5, 0.5), (0.5, 0.5, -0.5), (-0.5, -0.5, -0.5))


@dataclass
class AttitudeGains:
    """Inner-loop gains, per axis (roll, pitch, yaw); ArduCopter ATC_* defaults (PX4 MC_* map onto the same).

    Units: angle P in (rad/s)/rad; rate P/I/D in normalised output per rad/s (per rad, per rad/s^2), IMAX in
    normalised output; filters in Hz; accel limits rad/s^2; input_tc s.
    """

    ang_p: list[float] = field(default_factory=lambda: [4.5, 4.5, 4.5])  # ATC_ANG_RLL/PIT/YAW_P
    rat_p: list[float] = field(default_factory=lambda: [0.135, 0.135, 0.18])  # ATC_RAT_RLL/PIT/YAW_P
    rat_i: list[float] = field(default_factory=lambda: [0.135, 0.135, 0.018])
    rat_d: list[float] = field(default_factory=lambda: [0.0036, 0.0036, 0.0])
    rat_imax: list[float] = field(default_factory=lambda: [0.5, 0.5, 0.5])
    rat_fltt_hz: float = 20.0
    rat_fltd_hz: float = 20.0
    input_tc: float = 0.15  # ATC_INPUT_TC
    accel_max: list[float] = field(  # ATC_ACCEL_R/P/Y_MAX 110000, 110000, 27000 cdeg/s^2
        default_factory=lambda: [math.radians(1100.0), math.radians(1100.0), math.radians(270.0)])


def _alpha(hz: float, dt: float) -> float:
    """First-order low-pass coefficient (ArduPilot LowPassFilter): 1 = no filtering."""
    if hz <= 0.0:
        return 1.0
    rc = 1.0 / (2.0 * math.pi * hz)
    return dt / (dt + rc)


def sqrt_controller(error: float, p: float, accel_max: float, dt: float) -> float:
    """ArduPilot's sqrt_controller: P near zero, sqrt(2 a e) far away so the target can stop without overshoot.

    error in rad, p in 1/s, accel_max in rad/s^2; returns the desired rate in rad/s.
    """
    if accel_max <= 0.0 or p <= 0.0:
        out = error * p
    else:
        lin = accel_max / (p * p)
        if error > lin:
            out = math.sqrt(2.0 * accel_max * (error - 0.5 * lin))
        elif error < -lin:
            out = -math.sqrt(2.0 * accel_max * (-error - 0.5 * lin))
        else:
            out = error * p
    # Never ask for more than closes the error within one step.
    lim = abs(error) / dt
    return min(max(out, -lim), lim)


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
        self._alpha_key: tuple[float, float] | None = None
        self._alphas = (1.0, 1.0)

    def update(self, roll_d: float, pitch_d: float, yaw_d: float, rpy: Sequence[float], rates: Sequence[float],
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
        amax = g.accel_max
        for i in range(3):
            err = desired[i] - self.att_t[i]
            if i == 2:
                err = (err + math.pi) % (2.0 * math.pi) - math.pi
            want = sqrt_controller(err, 1.0 / max(g.input_tc, 1e-3), amax[i], dt)
            step = amax[i] * dt
            self.rate_t[i] += min(max(want - self.rate_t[i], -step), step)
            self.att_t[i] += self.rate_t[i] * dt
        phi, theta, psi = rpy[0], rpy[1], rpy[2]
        # Angle P on the shaped target plus its rate as feed-forward (Euler rates).
        e_r = self.att_t[0] - phi
        e_p = self.att_t[1] - theta
        e_y = (self.att_t[2] - psi + math.pi) % (2.0 * math.pi) - math.pi
        dphi = self.rate_t[0] + g.ang_p[0] * e_r
        dtheta = self.rate_t[1] + g.ang_p[1] * e_p
        dpsi = self.rate_t[2] + g.ang_p[2] * e_y
        # Euler rates -> body rates (the loops run in body axes, as ArduPilot's do).
        sphi, cphi = math.sin(phi), math.cos(phi)
        sth, cth = math.sin(theta), math.cos(theta)
        body_t = (dphi - sth * dpsi, cphi * dtheta + sphi * cth * dpsi, -sphi * dtheta + cphi * cth * dpsi)
        kp, ki, kd, imax = g.rat_p, g.rat_i, g.rat_d, g.rat_imax
        key = (g.rat_fltt_hz, g.rat_fltd_hz)
        if key != self._alpha_key:  # filter coefficients only change with the parameters
            self._alpha_key, self._alphas = key, (_alpha(key[0], dt), _alpha(key[1], dt))
        at, ad = self._alphas
        for i in range(3):
            self.r_tgt[i] += at * (body_t[i] - self.r_tgt[i])
            err = self.r_tgt[i] - rates[i]
            der = (err - self.r_err[i]) / dt
            self.r_err[i] = err
            self.r_der[i] += ad * (der - self.r_der[i])
            # Integrator clamped to +-IMAX (AC_PID's limit; no further anti-windup).
            self.r_int[i] = min(max(self.r_int[i] + ki[i] * err * dt, -imax[i]), imax[i])
            self.out[i] = kp[i] * err + self.r_int[i] + kd[i] * self.r_der[i]
        return self.mix(collective, self.out[0], self.out[1], self.out[2])

    def mix(self, collective: float, roll: float, pitch: float, yaw: float) -> np.ndarray:
        """Normalised outputs -> per-motor thrust (N), roll/pitch first, then throttle, then yaw headroom.

        Closed form of ``thr + MIX[i] . (roll, pitch, yaw)`` for the X frame (rows FR, AL, FL, AR).
        """
        roll = min(max(roll, -1.0), 1.0)
        pitch = min(max(pitch, -1.0), 1.0)
        a = 0.5 * (pitch - roll)  # FR gets +a, AL -a
        b = 0.5 * (pitch + roll)  # FL gets +b, AR -b
        hi = max(abs(a), abs(b))
        # Shift the collective so roll/pitch fit in 0..1 (attitude has priority over altitude, as in AP).
        thr = min(max(collective, hi), 1.0 - hi) if hi <= 0.5 else 0.5
        # Yaw gets what headroom is left (each motor moves by yaw / 2).
        room = 2.0 * max(min(1.0 - thr - hi, thr - hi), 0.0)
        y = 0.5 * min(max(yaw, -room), room)
        tmax = self.af.thrust_max
        return np.array([min(max(thr + a + y, 0.0), 1.0), min(max(thr - a + y, 0.0), 1.0),
                         min(max(thr + b - y, 0.0), 1.0), min(max(thr - b - y, 0.0), 1.0)]) * tmax
