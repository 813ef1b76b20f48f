"""Figure-8 tracking episodes: many gain vectors / initial conditions flown at once.

Timing follows SCG: at control step k the controller sees reference X_GOAL[k] (time k*dt), the plant
integrates one period, and the cost compares the new state with X_GOAL[k+1]. An episode stops early as
soon as the state leaves the environment bounds; the number of control steps flown is L.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ksbo_sim.constants import SCG_CRAZYFLIE, QuadConstants
from ksbo_sim.dynamics import integrate
from ksbo_sim.pid import PlanarPID
from ksbo_sim.plants import ActuatorState, Plant
from ksbo_task.figure8 import Figure8
from ksbo_task.limit_checks import NO_TRIP, MonitorLimits, Outcome, planar_monitor_limits, trip_codes

#: Crash codes stored in :attr:`Rollout.reason`.
OK, OUT_X, GROUND, CEILING, TILT = 0, 1, 2, 3, 4
REASONS = {OK: "completed", OUT_X: "|x| > x limit", GROUND: "hit the ground", CEILING: "z above ceiling",
           TILT: "pitch beyond tilt limit"}


@dataclass(frozen=True)
class Bounds:
    """Environment bounds (SCG quadrotor ``_get_done``); leaving them ends the episode (unsafe)."""

    x_max: float = 2.0
    z_min: float = -0.05
    z_max: float = 2.0
    tilt_max_deg: float = 85.0

    def violation(self, state: np.ndarray) -> np.ndarray:
        """(B,) crash code of each state (0 = inside). NaN states count as leaving the box."""
        x, z, th = state[:, 0], state[:, 2], state[:, 4]
        code = np.zeros(state.shape[0], dtype=np.int8)
        code[~(np.abs(th) <= math.radians(self.tilt_max_deg))] = TILT
        code[~(z <= self.z_max)] = CEILING
        code[~(z >= self.z_min)] = GROUND
        code[~(np.abs(x) <= self.x_max)] = OUT_X
        return code


#: Default backup controller: the task's known-safe gains a0 (fact sheet part C).
BACKUP_GAINS = (0.15, 0.0, 0.1, 0.5, 0.0, 0.2, 3.0e4, 0.0, 1.0e4)


@dataclass(frozen=True)
class MonitorConfig:
    """In-flight monitor and backup: on a trip the flight switches to ``backup`` gains holding ``hold``.

    Attributes:
        limits: trip thresholds (:func:`ksbo_task.limit_checks.trip_codes`).
        backup: (9,) backup gains (the baseline a0 by default).
        hold: (x, z) point the backup holds.
        recover_steps: control steps the backup must stay inside the environment bounds for the flight to count
            as recovered (``aborted``); leaving them is ``crashed``.
        attitude_priority: the backup's mixer keeps torque authority (:class:`ksbo_sim.pid.PlanarPID`), as
            ArduPilot's mixer and PX4's airmode do; SCG's mixer (the trials') loses it whenever the position loop asks
            for less than the minimum thrust, and a vehicle tripped while climbing or pitching then tumbles on.
    """

    limits: MonitorLimits = field(default_factory=planar_monitor_limits)
    backup: tuple[float, ...] = BACKUP_GAINS
    hold: tuple[float, float] = (0.0, 1.0)
    recover_steps: int = 150
    attitude_priority: bool = True


@dataclass(frozen=True)
class EpisodeConfig:
    """Episode settings; defaults are the shared fact sheet's recommendations (part C).

    ``plant`` (None = nominal) changes the true vehicle (``ksbo_sim.plants``); ``monitor`` (None = the paper's
    strict mode: no monitor, leaving the bounds ends the episode) adds the abort-and-recover monitor.
    """

    ctrl_freq: int = 50
    phys_freq: int = 1000
    laps: int = 2
    figure8: Figure8 = field(default_factory=Figure8)
    bounds: Bounds = field(default_factory=Bounds)
    constants: QuadConstants = SCG_CRAZYFLIE
    plant: Plant | None = None
    monitor: MonitorConfig | None = None

    @property
    def dt(self) -> float:
        return 1.0 / self.ctrl_freq

    @property
    def n_sub(self) -> int:
        if self.phys_freq % self.ctrl_freq:
            raise ValueError("phys_freq must be a multiple of ctrl_freq")
        return self.phys_freq // self.ctrl_freq

    @property
    def steps(self) -> int:
        """Control steps in a full episode (600 for 2 laps of 6 s at 50 Hz)."""
        return int(round(self.laps * self.figure8.period * self.ctrl_freq))

    def reference(self) -> np.ndarray:
        """(steps + 1, 6) reference states X_GOAL[k] at t = k dt."""
        return self.figure8.state(np.arange(self.steps + 1) * self.dt)


@dataclass
class Rollout:
    """Result of :func:`simulate` for B episodes of N control steps.

    Attributes:
        t: (N + 1,) times of the state samples.
        states: (B, N + 1, 6) states; row 0 is the initial state; NaN after an early stop.
        refs: (N + 1, 6) reference states X_GOAL.
        inputs: (B, N, 2) thrusts applied during step k; NaN after an early stop.
        L: (B,) control steps of the mission flown (up to the crash or the monitor's trip).
        reason: (B,) crash code (see ``REASONS``), 0 for a completed episode or a recovered abort.
        trip: (B,) monitor trip code (``ksbo_task.limit_checks``; 0 = no trip) or None without a monitor.
    """

    t: np.ndarray
    states: np.ndarray
    refs: np.ndarray
    inputs: np.ndarray
    L: np.ndarray
    reason: np.ndarray
    trip: np.ndarray | None = None

    @property
    def outcomes(self) -> list[Outcome]:
        """(B,) outcome of each episode: complete, aborted (the backup recovered) or crashed."""
        trip = np.zeros_like(self.reason) if self.trip is None else self.trip
        return [Outcome.CRASHED if r != OK else Outcome.ABORTED if t != NO_TRIP else Outcome.COMPLETE
                for r, t in zip(self.reason, trip)]

    @property
    def L_expected(self) -> int:
        return self.inputs.shape[1]


def simulate(gains: np.ndarray, init: np.ndarray, config: EpisodeConfig | None = None) -> Rollout:
    """Fly B figure-8 episodes at once.

    Args:
        gains: (B, 9) or (9,) PID gains (broadcast against ``init``).
        init: (B, 6) or (6,) initial states.
    Returns:
        A :class:`Rollout`. Crashed (and recovered) episodes leave the working batch, so a batch that is mostly
        unsafe is cheap. With a monitor, states after a trip are the backup's flight (L stays at the trip step).
    """
    config = config or EpisodeConfig()
    gains = np.atleast_2d(np.asarray(gains, dtype=float))
    init = np.atleast_2d(np.asarray(init, dtype=float))
    B = max(gains.shape[0], init.shape[0])
    gains = np.broadcast_to(gains, (B, 9)).copy()
    init = np.broadcast_to(init, (B, 6)).copy()
    N, dt, n_sub, c = config.steps, config.dt, config.n_sub, config.constants
    plant, mon = config.plant, config.monitor
    c_true = c if plant is None else plant.constants(c)
    noise, gust = (None, None) if plant is None else plant.disturbances(init, N, dt)
    act = None if plant is None else ActuatorState(plant, dt)
    refs = config.reference()
    states = np.full((B, N + 1, 6), np.nan)
    inputs = np.full((B, N, 2), np.nan)
    states[:, 0] = init
    L = np.full(B, N, dtype=np.int64)
    reason = np.zeros(B, dtype=np.int8)
    trip = None if mon is None else np.zeros(B, dtype=np.int8)
    tripped_at = np.full(B, -1, dtype=np.int64)

    active = np.arange(B)
    s = init.copy()
    pid = PlanarPID(gains, c, dt)
    pid.reset()
    for k in range(N):
        meas = s if noise is None else s + noise[active, k]
        ref_pos = np.broadcast_to(refs[k, (0, 2)], (active.size, 2)).copy()
        ref_vel = np.broadcast_to(refs[k, (1, 3)], (active.size, 2)).copy()
        backing = tripped_at[active] >= 0
        if backing.any():
            ref_pos[backing] = mon.hold
            ref_vel[backing] = 0.0
        u = pid(meas, ref_pos, ref_vel)
        s = integrate(s, u if act is None else act.apply(u), c_true, dt, n_sub,
                      None if gust is None else gust[active, k])
        states[active, k + 1] = s
        inputs[active, k] = u
        code = config.bounds.violation(s)
        done = code != OK
        if done.any():
            gone = active[done]
            L[gone] = np.where(tripped_at[gone] >= 0, L[gone], k + 1)
            reason[gone] = code[done]
        if mon is not None:
            new = (trip_codes(mon.limits, s, refs[k + 1, (0, 2)]) != NO_TRIP) & ~backing & ~done
            if new.any():
                rows = active[new]
                trip[rows] = trip_codes(mon.limits, s[new], refs[k + 1, (0, 2)])
                tripped_at[rows], L[rows] = k + 1, k + 1
                pid.gains[new] = mon.backup
                pid.int_pos[new] = 0.0
                pid.int_pitch[new] = 0.0
                pid.attitude_priority[new] = mon.attitude_priority
            done |= backing & (k + 1 - tripped_at[active] >= mon.recover_steps)
        if done.any():
            keep = ~done
            active, s = active[keep], s[keep]
            pid.select(keep)
            if act is not None:
                act.select(keep)
            if active.size == 0:
                break
    return Rollout(t=np.arange(N + 1) * dt, states=states, refs=refs, inputs=inputs, L=L, reason=reason,
                   trip=trip)
