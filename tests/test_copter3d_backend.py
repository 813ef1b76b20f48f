"""JSBSim F450 backend: motor mapping, calibration, silence, reset without reload."""

import numpy as np
import pytest

from ksbo_sim.copter3d.attitude import MIX
from ksbo_sim.copter3d.backend import LBFT, MOTORS, F450Backend


@pytest.fixture(scope="module")
def backend():
    return F450Backend(rotor_drag=0.0)


def _held_moments(b: F450Backend, cmd: np.ndarray) -> np.ndarray:
    b.reset(np.array([0.0, 0.0, -10.0]))
    b.hold(True)
    b.set_motors(cmd)
    b.run(500)
    f = b.fdm
    out = np.array([f["moments/l-prop-lbsft"], f["moments/m-prop-lbsft"], f["moments/n-prop-lbsft"]]) * LBFT
    b.hold(False)
    return out


def test_hover_calibration_matches_the_f450(backend):
    af = backend.airframe
    assert af.mass == pytest.approx(1.4, rel=1e-3)
    assert af.inertia == pytest.approx([0.019, 0.019, 0.0252], rel=1e-3)
    hover_cmd = float(af.command_for_thrust(af.mass * 9.80665 / 4))
    assert 0.39 < hover_cmd < 0.43  # fact sheet 7: ~0.415-0.42
    assert np.all(np.diff(af.thrust_table[:, 1]) > 0)


@pytest.mark.parametrize("motor", range(4))
def test_each_motor_moves_the_airframe_as_the_mixer_assumes(backend, motor):
    base = np.full(4, 0.4)
    cmd = base.copy()
    cmd[motor] = 0.5
    moment = _held_moments(backend, cmd) - _held_moments(backend, base)
    assert np.sign(moment) == pytest.approx(np.sign(MIX[motor])), MOTORS[motor]


def test_only_throttle_index_zero_reaches_the_escs(backend):
    """The F450 FCS mixes fcs/throttle-cmd-norm (= [0]) into all ESCs; [1..3] are read by nothing."""
    f = backend.fdm
    backend.reset(np.array([0.0, 0.0, -10.0]))
    backend.set_motors(np.zeros(4))
    f["fcs/throttle-cmd-norm[1]"] = 0.5
    backend.run(5)
    assert [f[f"fcs/throttle-pos-norm[{i}]"] for i in range(4)] == [0.0] * 4
    f["fcs/throttle-cmd-norm[1]"] = 0.0


def test_reset_places_the_vehicle_without_reloading(backend):
    fdm = backend.fdm
    backend.reset(np.array([3.0, -2.0, -12.0]), np.array([1.0, 0.5, 0.0]))
    pos, vel, rpy, rates = backend.read()
    assert backend.fdm is fdm
    assert pos == pytest.approx([3.0, -2.0, -12.0], abs=1e-6)
    assert vel == pytest.approx([1.0, 0.5, 0.0], abs=1e-6)
    assert backend.time_s == 0.0
    # Props are already at hover speed after a reset: no free fall in the first 0.1 s.
    backend.set_motors(np.full(4, float(backend.airframe.command_for_thrust(backend.airframe.mass * 9.80665 / 4))))
    backend.run(int(round(0.1 / backend.dt)))
    assert abs(backend.read()[1][2]) < 0.05


def test_two_resets_give_the_same_trajectory(backend):
    def run():
        backend.reset(np.array([0.0, 0.0, -10.0]))
        backend.set_motors(np.array([0.45, 0.40, 0.42, 0.41]))
        backend.run(300)
        return np.concatenate(backend.read())

    assert run() == pytest.approx(run(), abs=0.0)


def test_loading_prints_nothing(capfd):
    F450Backend(rotor_drag=0.3)
    out, err = capfd.readouterr()
    assert out == "" and err == ""


def test_rotor_drag_slows_a_coasting_vehicle():
    def coast(c):
        b = F450Backend(rotor_drag=c)
        b.reset(np.array([0.0, 0.0, -50.0]), np.array([5.0, 0.0, 0.0]))
        b.set_motors(np.zeros(4))
        b.run(int(round(0.5 / b.dt)))  # 0.5 s ballistic
        return b.read()[1][0]

    v0, v3 = coast(0.0), coast(0.3)
    assert v0 > 4.8  # quadratic body drag only: nearly nothing at 5 m/s
    assert v3 == pytest.approx(5.0 * np.exp(-0.3 * 0.5), abs=0.15)


def test_mixer_is_the_mix_table_inside_the_limits(backend):
    from ksbo_sim.copter3d.attitude import AttitudeController

    ctrl = AttitudeController(backend.airframe, backend.dt)
    r, p, y = 0.1, -0.05, 0.08
    want = [0.4 + m[0] * r + m[1] * p + m[2] * y for m in MIX]
    assert ctrl.mix(0.4, r, p, y) == pytest.approx(np.array(want) * backend.airframe.thrust_max)
    # Saturation: roll/pitch are kept, the collective gives way, nothing leaves 0..1.
    out = ctrl.mix(0.98, 0.2, 0.0, 0.0) / backend.airframe.thrust_max
    assert out.max() <= 1.0 and out[2] - out[0] == pytest.approx(0.2)
