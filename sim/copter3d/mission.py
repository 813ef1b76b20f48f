"""The 3-D copter's horizontal figure-8 (:class:`ksbo_task.figure8_ne.Figure8H`, the mission the MAVLink client
streams) flown in process: :func:`fly` streams it one setpoint per control step into a vehicle model and
:func:`tracking_rms` scores the lap. The MAVLink stream's setpoints carry position + velocity + acceleration
(SET_POSITION_TARGET_LOCAL_NED type_mask 0x0C00 = 3072, frame LOCAL_NED); the tracking error is the measured
position minus the commanded position at the same time, and lap 2 (the steady state) is what is scored.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ksbo_sim.vehicle import Setpoint, VehicleModel
from ksbo_task.figure8_ne import Figure8H
from ksbo_task.limit_checks import tilt_rad

#: SET_POSITION_TARGET_LOCAL_NED type_mask for position + velocity + acceleration (yaw and yaw rate ignored).
TYPE_MASK_POS_VEL_ACC = 0x0C00
#: ... for position only (the end-of-mission hold target; fact sheet 4.1 step 8).
TYPE_MASK_POS = 0x0DF8
MAV_FRAME_LOCAL_NED = 1


def tracking_rms(t: np.ndarray, pos: np.ndarray, fig: Figure8H, t0: float, t1: float,
                 axes: tuple[int, ...] = (0, 1, 2)) -> float:
    """RMS (m) over samples with t0 <= t < t1 of |measured - commanded| on ``axes``; pos (n, 3), t (n,)."""
    sel = (t >= t0 - 1e-9) & (t < t1 - 1e-9)
    err = pos[sel][:, axes] - fig.position(t[sel])[:, axes]
    return float(np.sqrt(np.mean(np.sum(err * err, axis=1))))


@dataclass
class Flight:
    """Result of :func:`fly`: sample times (n,), measured NED positions (n, 3), crash code, lap-2 RMS (m)."""

    t: np.ndarray
    pos: np.ndarray
    crashed: int
    rms_lap2: float
    rms_all: float
    rms_lap2_axes: tuple[float, float, float]
    max_error: float  # m, largest |measured - commanded| over the whole flight (lap 1 start transient)
    max_tilt_deg: float  # largest tilt of the body's z axis from the vertical, as the tuner's monitor judges it


def fly(vehicle: VehicleModel, fig: Figure8H | None = None) -> Flight:
    """Hover at the start point, then stream ``fig`` at its rate in process (one vehicle step per setpoint).

    The vehicle is reset airborne at the start point with zero velocity, as after a takeoff and settle; the
    sample after setpoint k is compared with the reference at the next send time (what telemetry at that time
    would be scored against). Lap 2 = the last lap.
    """
    fig = fig or Figure8H()
    if abs(vehicle.ctrl_dt * fig.rate_hz - 1.0) > 1e-9:
        raise ValueError("fly() streams one setpoint per control period: rate_hz must be 1 / ctrl_dt")
    vehicle.reset(pos=fig.start())
    times = fig.sample_times()
    pos = np.empty((len(times), 3))
    tilt = np.zeros(len(times))
    crashed = 0
    n = 0
    for k, tk in enumerate(times):
        pos_ref, vel_ref, acc_ref = fig.state(float(tk))
        st = vehicle.step(Setpoint(pos=pos_ref, vel=vel_ref, acc=acc_ref))
        pos[k] = st.pos
        tilt[k] = tilt_rad(float(st.rpy[0]), float(st.rpy[1]))
        n = k + 1
        if st.crashed:
            crashed = st.crashed
            break
    t_meas = (np.arange(n) + 1) / fig.rate_hz
    pos = pos[:n]
    lap2 = (fig.duration - fig.period, fig.duration)
    max_err = float(np.max(np.linalg.norm(pos - fig.position(t_meas), axis=1))) if n else float("nan")
    max_tilt = float(np.degrees(np.max(tilt[:n]))) if n else float("nan")
    if crashed or n < len(times):
        nan = float("nan")
        return Flight(t_meas, pos, crashed, nan, nan, (nan, nan, nan), max_err, max_tilt)
    axes = tuple(tracking_rms(t_meas, pos, fig, *lap2, axes=(i,)) for i in range(3))
    return Flight(t_meas, pos, crashed, tracking_rms(t_meas, pos, fig, *lap2),
                  tracking_rms(t_meas, pos, fig, 0.0, fig.duration), axes, max_err, max_tilt)  # type: ignore[arg-type]
