"""The in-process monitor and backup: aborted vs crashed flights, plant variants, one limit check."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from ksbo_mav.opt.evaluation import Evaluation
from ksbo_mav.simulated.planar_objective import SimObjective
from ksbo_sim.episode import BACKUP_GAINS, EpisodeConfig, MonitorConfig, simulate
from ksbo_sim.plants import PLANTS
from ksbo_task.limit_checks import FENCE, TILT, TRACK, MonitorLimits, Outcome, check_state, trip_codes
from ksbo_task.starts import fixed_initial_states

A0 = np.array(BACKUP_GAINS)
SLOW = np.array([0.15, 0.5, 0.1, 0.5, 0.0, 0.2, 3e4, 0.0, 1e4])  # Ix 0.5: the x loop winds up over seconds
FAST = np.array([0.15, 0.0, 0.1, 0.5, 0.0, 0.2, 3e4, 0.0, 0.0])  # Dθ 0: pitch diverges within a second
INIT = fixed_initial_states()


def test_slow_divergence_is_aborted_and_recovered() -> None:
    strict = simulate(SLOW, INIT[1])
    assert strict.reason[0] != 0 and strict.trip is None  # the paper's mode: a crash
    r = simulate(SLOW, INIT[1], EpisodeConfig(monitor=MonitorConfig()))
    assert r.outcomes == [Outcome.ABORTED]
    k = int(r.L[0])
    assert k < strict.L[0] and r.trip[0] != 0
    # After the trip the backup (a0 holding (0, 1)) flew recover_steps inside the environment bounds.
    after = r.states[0, k : k + MonitorConfig().recover_steps + 1]
    assert np.all(np.isfinite(after)) and np.all(np.abs(after[:, 0]) <= 2.0) and np.all(after[:, 2] >= -0.05)
    assert np.hypot(after[-1, 0], after[-1, 2] - 1.0) < np.hypot(after[0, 0], after[0, 2] - 1.0)


def test_fast_divergence_is_a_crash_even_with_the_backup() -> None:
    r = simulate(FAST, INIT[0], EpisodeConfig(monitor=MonitorConfig()))
    assert r.trip[0] == TILT  # the monitor tripped first ...
    assert r.reason[0] != 0 and r.outcomes == [Outcome.CRASHED]  # ... but the backup could not recover


def test_baseline_completes_on_every_plant_with_monitor_and_is_safe() -> None:
    for name in PLANTS:
        obj = SimObjective(seed=0, plant=name, monitor=True)
        P, counts = obj.expected_outcomes(A0)
        assert counts.tolist() == [[8, 0, 0]], name
        assert P[0] > 0.0, name


def test_plants_change_the_flight_and_rows_do_not_depend_on_the_batch() -> None:
    nominal = SimObjective(seed=0).expected(A0)[0]
    for name in ("mass+30", "iyy x0.5", "delay 40ms", "gusts"):
        cfg = EpisodeConfig(plant=PLANTS[name])
        r = simulate(A0, INIT, cfg)
        r_one = simulate(A0, INIT[3], cfg)
        np.testing.assert_allclose(r.states[3], r_one.states[0], rtol=0, atol=1e-12)
        assert not np.allclose(r.states, simulate(A0, INIT).states, equal_nan=True), name
    assert SimObjective(seed=0, plant="nominal").expected(A0)[0] == pytest.approx(nominal, abs=1e-12)


def test_sim_objective_reports_outcomes() -> None:
    obj = SimObjective(seed=3, monitor=True)
    ev = obj(SLOW)
    assert isinstance(ev, Evaluation) and ev.outcome is Outcome.ABORTED and ev.value < 0
    assert isinstance(SimObjective(seed=3)(A0), float)  # strict mode stays a plain float


def test_one_limit_check_for_batch_sample_and_mavlink() -> None:
    from ksbo_mav.mav.monitor import Limits, Monitor

    lim = MonitorLimits(x_max=1.5, z_min=0.2, z_max=1.8, tilt_max_deg=60, tracking_error_max=0.8)
    states = np.array([[0, 0, 1, 0, 0, 0], [1.6, 0, 1, 0, 0, 0], [0, 0, 1, 0, 1.2, 0], [0.5, 0, 1.7, 0, 0, 0]])
    ref = np.array([0.0, 1.0])
    assert trip_codes(lim, states, ref).tolist() == [0, FENCE, TILT, TRACK]
    names = [None, "fence", "tilt", "track"]
    for s, want in zip(states, names):
        got = check_state(lim, s[0], 0.0, s[2], s[4], (0.0, 0.0, 1.0))
        assert (got and got[0]) == want
    mon = Monitor(Limits(x_max=1.5, z_min=0.2, z_max=1.8, tilt_max_deg=60, tracking_error_max=0.8), guided_mode=4)
    for s, want in zip(states, names):
        lpn = SimpleNamespace(x=s[0], y=0.0, z=-s[2])
        att = SimpleNamespace(pitch=s[4], roll=0.0)
        got = mon.check_sample(lpn, att, np.array([0.0, 0.0, -1.0]))
        assert (got and got[0]) == want
    assert mon.check_sample(SimpleNamespace(x=math.nan, y=0.0, z=-1.0), None, None)[0] == "fence"


def test_the_tilt_is_the_body_axis_from_the_vertical_not_the_larger_euler_angle() -> None:
    """Roll and pitch of 35 deg each lean the vehicle 47.8 deg: a 40 deg limit trips, neither angle past it."""
    from ksbo_mav.mav.monitor import Limits, Monitor

    mon = Monitor(Limits(x_max=15, y_max=15, z_min=2, z_max=20, tilt_max_deg=40, tracking_error_max=5), guided_mode=4)
    lpn = SimpleNamespace(x=0.0, y=0.0, z=-10.0)
    both = SimpleNamespace(roll=math.radians(35), pitch=math.radians(35))
    assert mon.check_sample(lpn, both, None) == ("tilt", "tilt 48 deg > 40 deg")
    assert mon.check_sample(lpn, SimpleNamespace(roll=math.radians(39), pitch=0.0), None) is None
    assert mon.check_sample(lpn, SimpleNamespace(roll=0.0, pitch=math.radians(-41)), None)[0] == "tilt"


def test_stopping_point_fence_trips_a_vehicle_racing_towards_the_box_edge() -> None:
    from ksbo_mav.mav.monitor import Monitor

    lim = MonitorLimits(x_max=1.6, z_min=0.2, z_max=1.8, tilt_max_deg=60, tracking_error_max=5.0, brake_accel=3.0)
    # x 1.0 m at +2.5 m/s stops at 1.0 + 2.5² / 6 = 2.04 m; at -2.5 m/s it is braking away from the edge.
    states = np.array([[1.0, 2.5, 1.0, 0, 0, 0], [1.0, -2.5, 1.0, 0, 0, 0], [0, 0, 0.5, -1.5, 0, 0],
                       [0, 0, 0.5, 1.5, 0, 0], [0.5, 1.0, 1.0, 0.5, 0, 0]])
    assert trip_codes(lim, states, None).tolist() == [FENCE, 0, FENCE, 0, 0]
    no_brake = MonitorLimits(x_max=1.6, z_min=0.2, z_max=1.8, tilt_max_deg=60, tracking_error_max=5.0)
    assert trip_codes(no_brake, states, None).tolist() == [0, 0, 0, 0, 0]
    mon = Monitor(lim, guided_mode=4)
    for s, want in zip(states, ["fence", None, "fence", None, None]):
        got = check_state(lim, s[0], 0.0, s[2], 0.0, None, (s[1], 0.0, s[3]))
        assert (got and got[0]) == want
        assert check_state(lim, s[0], 0.0, s[2], 0.0, None) is None  # without a velocity: the position only
        lpn = SimpleNamespace(x=s[0], y=0.0, z=-s[2], vx=s[1], vy=0.0, vz=-s[3])  # NED
        got = mon.check_sample(lpn, None, None)
        assert (got and got[0]) == want
    assert "stopping point" in check_state(lim, 1.0, 0.0, 1.0, 0.0, None, (2.5, 0.0, 0.0))[1]
    # a velocity that is not finite: the position only, and the message says so
    assert check_state(lim, 1.7, 0.0, 1.0, 0.0, None, (math.nan, 0.0, 0.0)) == ("fence", "|north| 1.70 m > 1.6 m")


def test_backup_mixer_keeps_torque_when_the_position_loop_asks_for_no_thrust() -> None:
    from ksbo_sim.constants import SCG_CRAZYFLIE
    from ksbo_sim.pid import PlanarPID

    # 0.3 m above the hold point and climbing, pitched 45° and pitching on: the position loop asks for fz < 0.
    state = np.array([[0.0, 0.5, 1.3, 0.8, math.radians(45), 2.0]] * 2)
    pid = PlanarPID(np.array([A0, A0]), SCG_CRAZYFLIE, 0.02)
    pid.reset(pitch=state[:, 4] - 2.0 * 0.02)
    pid.attitude_priority[1] = True
    T = pid(state, np.array([0.0, 1.0]), np.zeros(2))
    assert T[0, 0] == pytest.approx(T[0, 1])  # SCG's mixer: both motors at the minimum, the torque is lost
    assert T[1, 0] > T[1, 1] + 1e-3  # attitude priority: the torque that stops the pitch-up survives


def test_attitude_priority_turns_a_tumbling_trip_into_a_recovered_abort() -> None:
    # A trial of a ksbo run on nominal (tuning seed, monitor): the monitor trips at 60° tilt while the pitch loop
    # still rotates the vehicle; with SCG's mixer the backup asks for no thrust and the vehicle tumbles on.
    gains = np.array([0.1678, 0.0, 0.2605, 0.6207, 0.0317, 0.8031, 39445.9197, 35.6119, 7944.0933])
    init = np.array([0.0, -0.0003, 1.0, -0.0238, 0.0, 0.0])
    old = simulate(gains, init, EpisodeConfig(monitor=MonitorConfig(attitude_priority=False)))
    new = simulate(gains, init, EpisodeConfig(monitor=MonitorConfig()))
    assert old.trip[0] == new.trip[0] == TILT and old.L[0] == new.L[0]  # the same flight up to the same trip
    assert old.outcomes == [Outcome.CRASHED] and new.outcomes == [Outcome.ABORTED]


def test_a_limit_message_shows_the_value_past_the_limit() -> None:
    """Just past a limit, the message shows as many decimals as it takes to read value > limit (never "tilt 60 deg
    > 60 deg"); far past it, the usual few."""
    lim = MonitorLimits(x_max=15.0, y_max=8.0, z_min=4.0, z_max=16.0, tilt_max_deg=60.0, tracking_error_max=5.0)
    assert check_state(lim, 0.0, 0.0, 10.0, math.radians(60.4))[1] == "tilt 60.4 deg > 60 deg"
    assert check_state(lim, 0.0, 0.0, 10.0, math.radians(60.0004))[1] == "tilt 60.0004 deg > 60 deg"
    assert check_state(lim, 0.0, 0.0, 10.0, math.radians(71.2))[1] == "tilt 71 deg > 60 deg"
    assert check_state(lim, 15.001, 0.0, 10.0)[1] == "|north| 15.001 m > 15 m"
    assert check_state(lim, 0.0, 0.0, 3.9999)[1] == "height 3.9999 m outside [4, 16] m"
    assert check_state(lim, 0.0, 0.0, 10.0, 0.0, (0.0, 0.0, 15.0031))[1] == "tracking error 5.003 m > 5 m"
