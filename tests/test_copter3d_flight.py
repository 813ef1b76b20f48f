"""Copter3D flies like an ArduCopter in GUIDED: hover, steps, yaw, takeoff/landing, crashes, the figure-8."""

import math

import numpy as np
import pytest

from ksbo_sim.copter3d import Copter3D, fly
from ksbo_sim.copter3d.vehicle import FENCE_HOR, GROUND
from ksbo_sim.vehicle import Setpoint, VehicleModel
from ksbo_task.figure8_ne import Figure8H


@pytest.fixture(scope="module")
def legacy():
    return Copter3D("ardupilot-legacy")


def _hold(v, pos, steps, yaw=float("nan")):
    sp = Setpoint(pos=np.asarray(pos, dtype=float), yaw=yaw)
    return [v.step(sp) for _ in range(steps)]


def test_is_a_vehicle_model(legacy):
    assert isinstance(legacy, VehicleModel)
    assert legacy.ctrl_dt == pytest.approx(0.02)


def test_hover_holds(legacy):
    legacy.reset(np.array([2.0, -1.0, -10.0]))
    states = _hold(legacy, [2.0, -1.0, -10.0], 500)  # 10 s
    pos = np.array([s.pos for s in states])
    rpy = np.array([s.rpy for s in states])
    assert np.max(np.abs(pos - [2.0, -1.0, -10.0])) < 0.02
    assert np.max(np.abs(rpy[:, :2])) < math.radians(0.5)
    assert states[-1].thrust == pytest.approx(np.full(4, 1.4 * 9.80665 / 4), rel=0.02)
    assert all(s.crashed == 0 for s in states)


def test_position_step_settles_without_large_overshoot(legacy):
    legacy.reset(np.array([0.0, 0.0, -10.0]))
    states = _hold(legacy, [2.0, 0.0, -10.0], 400)  # 8 s
    north = np.array([s.pos[0] for s in states])
    assert north.max() < 2.0 * 1.3
    assert abs(north[-1] - 2.0) < 0.1
    assert max(abs(s.pos[2] + 10.0) for s in states) < 0.1  # altitude held while leaning
    assert max(abs(s.rpy[1]) for s in states) < math.radians(30.5)  # ANGLE_MAX 30 deg


def test_yaw_setpoint_is_followed(legacy):
    legacy.reset(np.array([0.0, 0.0, -10.0]))
    states = _hold(legacy, [0.0, 0.0, -10.0], 300, yaw=math.radians(90))
    assert states[-1].rpy[2] == pytest.approx(math.radians(90), abs=math.radians(3))
    assert np.linalg.norm(states[-1].pos - [0.0, 0.0, -10.0]) < 0.1


def test_takeoff_and_landing_from_the_ground(legacy):
    legacy.reset()  # home, on the ground
    assert legacy.landed
    idle = _hold(legacy, [0.0, 0.0, 0.0], 50)
    assert all(np.allclose(s.pos, 0.0, atol=1e-6) for s in idle)
    climb = _hold(legacy, [0.0, 0.0, -10.0], 750)  # 15 s
    assert not legacy.landed
    assert climb[-1].pos[2] == pytest.approx(-10.0, abs=0.2)
    land = _hold(legacy, [0.0, 0.0, 0.5], 750)  # target below ground: descend until touchdown
    assert legacy.landed
    assert land[-1].crashed == 0
    assert land[-1].pos[2] == pytest.approx(0.0, abs=0.05)


def test_leaving_the_geofence_is_a_crash_until_reset(legacy):
    legacy.reset(np.array([0.0, 0.0, -10.0]))
    legacy.set_param("FENCE_RADIUS", 10.0)
    try:
        states = _hold(legacy, [20.0, 0.0, -10.0], 500)
        codes = [s.crashed for s in states]
        assert FENCE_HOR in codes
        assert codes[-1] == FENCE_HOR and states[-1].crash_reason
        assert legacy.reset(np.array([0.0, 0.0, -10.0])).crashed == 0
    finally:
        legacy.set_param("FENCE_RADIUS", 100.0)


def test_falling_onto_the_ground_is_a_crash(legacy):
    legacy.reset(np.array([0.0, 0.0, -0.5]), np.array([0.0, 0.0, 8.0]))  # too close to stop
    states = _hold(legacy, [0.0, 0.0, 0.0], 100)
    assert states[-1].crashed == GROUND


def test_default_gains_track_the_figure8_like_arducopter_sitl(legacy):
    """Fact sheet 8: ArduCopter SITL lap-2 RMS ~0.2 m with pos+vel+acc setpoints, 10x worse on lap 1 peaks."""
    legacy.reset()
    f = fly(legacy, Figure8H())
    assert f.crashed == 0
    assert 0.05 < f.rms_lap2 < 0.6
    assert f.rms_all > f.rms_lap2  # lap 1 contains the start transient
    assert f.rms_lap2_axes[2] < 0.05  # altitude is held (horizontal pattern)


def test_error_falls_as_the_position_gain_rises(legacy):
    rms = []
    try:
        for p in (0.5, 1.0, 2.0):
            legacy.set_param("PSC_POSXY_P", p)
            f = fly(legacy, Figure8H())
            assert f.crashed == 0
            rms.append(f.rms_lap2)
    finally:
        legacy.set_param("PSC_POSXY_P", 1.0)
    assert rms[0] > 1.3 * rms[1] > 1.3 * 1.3 * rms[2]


def test_reset_without_reload_repeats_a_flight_exactly(legacy):
    fdm = legacy.backend.fdm
    a = fly(legacy, Figure8H(laps=1))
    b = fly(legacy, Figure8H(laps=1))
    assert legacy.backend.fdm is fdm
    assert np.array_equal(a.pos, b.pos)


def test_px4_personality_flies_the_figure8():
    v = Copter3D("px4")
    f = fly(v, Figure8H())
    assert f.crashed == 0
    assert 0.05 < f.rms_lap2 < 0.8


def _lap2_rms(drag: float = 1.0, wind: float = 0.0) -> float:
    """In process; the changed drag and wind hold over the flight's reset."""
    v = Copter3D("ardupilot")
    v.set_drag_scale(drag)
    v.set_wind(wind)
    return fly(v, Figure8H()).rms_lap2


def test_drag_and_wind_degrade_the_tracking_and_lost_thrust_does_not():
    calm = _lap2_rms()
    assert _lap2_rms(drag=2.0) > 1.8 * calm  # twice the drag: the lap RMS about doubles (0.216 -> 0.446 m)
    assert _lap2_rms(wind=6.0) > 1.1 * calm  # a steady 6 m/s wind (0.255 m)
    v = Copter3D("ardupilot")
    v.set_authority(0.6)  # the loops make up for lost thrust: the same tracking
    assert fly(v, Figure8H()).rms_lap2 == pytest.approx(calm, rel=0.02)
