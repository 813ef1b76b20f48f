"""The wind a multicopter flew in, inferred from its own telemetry when the autopilot does not estimate it.

What a flight log holds: the vehicle's velocity (``LOCAL_POSITION_NED``) and attitude (``ATTITUDE``). Newton's
second law, horizontally: the vehicle's acceleration is its thrust's horizontal part plus the air's drag. The thrust
points along the body's up axis, its size follows from the vertical balance, so the horizontal thrust is the lean
angle's doing; what is left over is drag, which depends on the velocity *through the air*, ``v - w``. Fitting the
drag model ``-(c_lin + c_quad |v - w|) (v - w)`` (linear momentum drag plus quadratic bluff-body drag, the model of
ArduPilot's and PX4's drag fusion) to every sample gives the wind ``w`` and the drag coefficients together. It needs
a flight whose ground velocity changes (the figure-8, the steps, a mission): in a still hover the lean angle tells
the drag, not how much of it is wind speed and how much is drag coefficient. The figure is an *inference* under
that model (an attitude offset such as a mis-levelled autopilot reads as wind: 1 degree ~ 0.17 m/s^2), and is
always labelled so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

G = 9.80665
#: Horizontal ground-speed spread (m/s, the standard deviation) below which wind and drag cannot be told apart.
MIN_SPEED_SPREAD = 0.7
#: Resampling step (s) of the fit: velocity differentiated and attitude averaged over it.
STEP_S = 0.1
#: Horizontal acceleration (m/s^2) above which a sample is left out of the fit.
MAX_ACCEL = 2.0


@dataclass(frozen=True)
class WindFit:
    """The inferred wind: ``north``/``east`` (m/s, the direction it blows towards), the drag coefficients and the
    RMS of the drag left unexplained (m/s^2) over ``n`` samples."""

    north: float
    east: float
    c_lin: float
    c_quad: float
    residual: float
    n: int

    @property
    def speed(self) -> float:
        return math.hypot(self.north, self.east)

    @property
    def from_deg(self) -> float:
        """Where the wind blows from, degrees clockwise from north (the meteorological convention)."""
        return (math.degrees(math.atan2(-self.east, -self.north)) + 360.0) % 360.0


def drag_samples(t: np.ndarray, vel: np.ndarray, att: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Horizontal ground velocity (m, 2) and drag acceleration (m, 2) on a :data:`STEP_S` grid from samples at
    times ``t`` (n,) s of the NED velocity ``vel`` (n, 3) and the attitude ``att`` (n, 3) roll, pitch, yaw (rad)."""
    from scipy.signal import savgol_filter

    grid = np.arange(t[0], t[-1], 0.02)
    if grid.size < 50:
        return np.zeros((0, 2)), np.zeros((0, 2))
    v = np.column_stack([np.interp(grid, t, vel[:, k]) for k in range(3)])
    yaw = np.unwrap(att[:, 2])
    roll, pitch, psi = (np.interp(grid, t, a) for a in (att[:, 0], att[:, 1], yaw))
    acc = savgol_filter(v, 25, 2, deriv=1, delta=0.02, axis=0)  # 0.5 s window
    # Body up axis in NED: the third column of the body-to-NED rotation.
    r02 = np.cos(psi) * np.sin(pitch) * np.cos(roll) + np.sin(psi) * np.sin(roll)
    r12 = np.sin(psi) * np.sin(pitch) * np.cos(roll) - np.cos(psi) * np.sin(roll)
    r22 = np.cos(pitch) * np.cos(roll)
    thrust = (G - acc[:, 2]) / r22  # specific thrust from the vertical balance (vertical drag neglected)
    drag = acc[:, :2] + thrust[:, None] * np.column_stack([r02, r12])
    k = int(round(STEP_S / 0.02))
    m = grid.size // k

    def mean(a: np.ndarray) -> np.ndarray:
        return a[:m * k].reshape(m, k, -1).mean(axis=1)

    # Hard manoeuvring (a corner, a step's start) is left out: there the lean leads the measured acceleration and
    # the difference would read as drag.
    calm = mean(np.linalg.norm(acc[:, :2], axis=1)[:, None])[:, 0] <= MAX_ACCEL
    return mean(v[:, :2])[calm], mean(drag)[calm]


def fit_wind(t: np.ndarray, vel: np.ndarray, att: np.ndarray) -> WindFit | None:
    """The wind and drag that explain the samples (module docstring); None when the ground velocity hardly changed
    (:data:`MIN_SPEED_SPREAD`) or the fit finds no drag at all."""
    from scipy.optimize import least_squares

    t, vel, att = np.asarray(t, float), np.asarray(vel, float), np.asarray(att, float)
    if t.size < 100:
        return None
    v, d = drag_samples(t, vel, att)
    if len(v) < 20 or float(np.sqrt(np.sum(np.var(v, axis=0)))) < MIN_SPEED_SPREAD:
        return None
    # Start from the linear model d = -c (v - w) = -c v + c w, solved in closed form.
    a = np.zeros((2 * len(v), 3))
    a[0::2, 0], a[1::2, 0] = -v[:, 0], -v[:, 1]
    a[0::2, 1], a[1::2, 2] = 1.0, 1.0
    sol, *_ = np.linalg.lstsq(a, d.reshape(-1), rcond=None)
    c0 = max(float(sol[0]), 1e-3)
    w0 = sol[1:] / c0

    def resid(p: np.ndarray) -> np.ndarray:
        va = v - p[2:]
        return (d + (p[0] + p[1] * np.linalg.norm(va, axis=1))[:, None] * va).reshape(-1)

    best = None
    for start in (np.array([c0, 0.0, *w0]), np.array([0.05, 0.05, *w0]), np.array([0.1, 0.02, 0.0, 0.0])):
        r = least_squares(resid, start, bounds=([0.0, 0.0, -40.0, -40.0], [5.0, 2.0, 40.0, 40.0]),
                          loss="soft_l1", f_scale=0.3)  # a gust or a glitch does not drag the fit
        if best is None or r.cost < best.cost:
            best = r
    c_lin, c_quad, wn, we = (float(x) for x in best.x)
    if c_lin + c_quad <= 1e-4:
        return None
    rms = float(np.sqrt(np.mean(resid(best.x) ** 2)))
    return WindFit(wn, we, c_lin, c_quad, rms, len(v))


def wind_from_lean(t: np.ndarray, vel: np.ndarray, att: np.ndarray, c_lin: float, c_quad: float) -> WindFit | None:
    """The wind during a hover from the mean lean angle that held the vehicle against it, with drag coefficients
    fitted on another flight of the same vehicle (:func:`fit_wind`): at rest the drag is ``(c_lin + c_quad |w|) w``,
    solved for ``|w|``. None without samples or drag coefficients."""
    v, d = drag_samples(np.asarray(t, float), np.asarray(vel, float), np.asarray(att, float))
    if len(v) < 20 or c_lin + c_quad <= 1e-4:
        return None
    mean_d = d.mean(axis=0) + (c_lin + c_quad * np.linalg.norm(v, axis=1).mean()) * v.mean(axis=0)  # ground motion
    mag = float(np.linalg.norm(mean_d))
    s = mag / c_lin if c_quad <= 1e-6 else (-c_lin + math.sqrt(c_lin ** 2 + 4 * c_quad * mag)) / (2 * c_quad)
    unit = mean_d / mag if mag > 0 else np.zeros(2)
    rms = float(np.sqrt(np.mean(np.sum((d - d.mean(axis=0)) ** 2, axis=1))))
    return WindFit(float(s * unit[0]), float(s * unit[1]), c_lin, c_quad, rms, len(v))


def tlog_series(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The vehicle's ``LOCAL_POSITION_NED`` velocity and ``ATTITUDE`` from a tlog, on the vehicle clock:
    ``t`` (n,) s, ``vel`` (n, 3) and ``att`` (n, 3) roll, pitch, yaw interpolated at the velocity's times."""
    from pymavlink import mavutil

    pos, att = [], []
    mlog = mavutil.mavlink_connection(str(path), dialect="ardupilotmega", robust_parsing=True)
    try:
        while True:
            m = mlog.recv_match(type=["LOCAL_POSITION_NED", "ATTITUDE"])
            if m is None:
                break
            if m.get_srcSystem() == 255 or m.get_srcComponent() not in (1,):
                continue
            if m.get_type() == "LOCAL_POSITION_NED":
                pos.append((m.time_boot_ms * 1e-3, m.vx, m.vy, m.vz))
            else:
                att.append((m.time_boot_ms * 1e-3, m.roll, m.pitch, m.yaw))
    finally:
        mlog.close()
    if len(pos) < 2 or len(att) < 2:
        return np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3))
    p = np.array(sorted(pos))
    a = np.array(sorted(att))
    yaw = np.unwrap(a[:, 3])
    t = p[:, 0]
    ok = (t >= a[0, 0]) & (t <= a[-1, 0])
    t = t[ok]
    return t, p[ok, 1:4], np.column_stack([np.interp(t, a[:, 0], a[:, 1]), np.interp(t, a[:, 0], a[:, 2]),
                                           np.interp(t, a[:, 0], yaw)])


def wind_from_tlog(path: str | Path) -> WindFit | None:
    """:func:`fit_wind` on a flight's tlog; None when it cannot tell (see there) or the log holds too little."""
    t, vel, att = tlog_series(path)
    return fit_wind(t, vel, att) if t.size else None
