"""Horizontal figure-8 mission of the 3-D copter (fact sheet section 8) and an in-process flight helper.

Reference (local NED, metres): north = A sin(wt), east = B sin(2wt), down = -altitude, w = 2 pi / period
(``second_axis=2`` puts the B term on down instead: the fact sheet's x-z variant);
defaults A = 10 m, B = 2.5 m, period 20 s, altitude 10 m: peak speed 3.1 m/s, peak acceleration 1.0 m/s^2
(x) / 1.0 m/s^2 (y). The client streams pos+vel+acc setpoints from it (SET_POSITION_TARGET_LOCAL_NED type_mask
0x0C00 = 3072, frame LOCAL_NED) at ``rate_hz``; the tracking error is the measured position minus the
commanded position at the same time, and lap 2 (the steady state) is what is scored. ``lead_in`` > 0 starts the
pattern from rest (:mod:`ksbo_sim.lead_in`; the vehicle profiles' ``[mission] lead_in_s``), so a hovering
vehicle does not see a 3.5 m/s velocity step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ksbo_sim.lead_in import lead_in_phase
from ksbo_sim.vehicle import Setpoint, VehicleModel

#: SET_POSITION_TARGET_LOCAL_NED type_mask for position + velocity + acceleration (yaw and yaw rate ignored).
TYPE_MASK_POS_VEL_ACC = 0x0C00
#: ... for position only (the end-of-mission hold target; fact sheet 4.1 step 8).
TYPE_MASK_POS = 0x0DF8
MAV_FRAME_LOCAL_NED = 1


@dataclass(frozen=True)
class Figure8H:
    """Horizontal figure-8 (north-east plane) at constant altitude; times in s from the mission start."""

    amp_north: float = 10.0  # m
    amp_east: float = 2.5  # m
    period: float = 20.0  # s
    altitude: float = 10.0  # m above home
    laps: int = 2
    rate_hz: float = 50.0
    second_axis: int = 1  # 1: east (horizontal pattern, the mission); 2: down (fact sheet's x-z variant)
    lead_in: float = 0.0  # s: start from rest (ksbo_sim.lead_in); 0 = the fact sheet's pattern from t = 0

    @property
    def omega(self) -> float:
        return 2.0 * math.pi / self.period

    @property
    def duration(self) -> float:
        return self.laps * self.period

    def position(self, t: np.ndarray | float) -> np.ndarray:
        """(*t.shape, 3) NED position in m."""
        return self._pattern(lead_in_phase(t, self.lead_in)[0], 0)

    def velocity(self, t: np.ndarray | float) -> np.ndarray:
        """(*t.shape, 3) NED velocity in m/s."""
        return self.state(t)[1]

    def acceleration(self, t: np.ndarray | float) -> np.ndarray:
        """(*t.shape, 3) NED acceleration in m/s^2."""
        return self.state(t)[2]

    def state(self, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(position, velocity, acceleration), each (*t.shape, 3), with the lead-in's phase computed once (the
        setpoint stream asks for all three at every step)."""
        ph, rate, rate_dot = lead_in_phase(t, self.lead_in)
        d1 = self._pattern(ph, 1)
        return (self._pattern(ph, 0), d1 * rate[..., None],
                self._pattern(ph, 2) * (rate * rate)[..., None] + d1 * rate_dot[..., None])

    def _pattern(self, ph: np.ndarray, order: int) -> np.ndarray:
        """(*ph.shape, 3) ``order``-th time derivative (0, 1, 2) of the unwarped pattern at phase ``ph`` (s)."""
        w = self.omega
        out = np.zeros(ph.shape + (3,))
        # d^k/dt^k sin(a t) = a^k sin(a t + k pi / 2)
        out[..., 0] = self.amp_north * w**order * np.sin(w * ph + order * math.pi / 2)
        if order == 0:
            out[..., 2] = -self.altitude
        out[..., self.second_axis] += self.amp_east * (2 * w) ** order * np.sin(2 * w * ph + order * math.pi / 2)
        return out

    def setpoint(self, t: float) -> Setpoint:
        """The pos+vel+acc setpoint to send at mission time t."""
        pos, vel, acc = self.state(t)
        return Setpoint(pos=pos, vel=vel, acc=acc)

    def start(self) -> np.ndarray:
        """(3,) where the vehicle should hover before the stream starts (the crossing point)."""
        return self.position(0.0)

    def sample_times(self) -> np.ndarray:
        """(n,) send times 0, 1/rate, ... < duration."""
        return np.arange(int(round(self.duration * self.rate_hz))) / self.rate_hz


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
    max_tilt_deg: float  # largest roll or pitch magnitude


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
        st = vehicle.step(fig.setpoint(float(tk)))
        pos[k] = st.pos
        tilt[k] = max(abs(st.rpy[0]), abs(st.rpy[1]))
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
