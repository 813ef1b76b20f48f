"""Unit tests without sockets: the planar VehicleModel, parameter encodings, personalities, estimator."""

from __future__ import annotations

import numpy as np
import pytest

from ksbo_mav.profiles import load_profile
from ksbo_sim import EpisodeConfig, simulate
from ksbo_sim.estimator import Estimator
from ksbo_sim.mavlink.params import ParamTable, decode_int, encode_int
from ksbo_sim.mavlink.personality import ARDUPILOT, OURS, PX4, Mode
from ksbo_sim.planar_vehicle import PlanarVehicle
from ksbo_sim.vehicle import ParamSpec, Setpoint, VehicleModel


def test_planar_vehicle_reproduces_simulate_bit_for_bit():
    cfg = EpisodeConfig()
    refs = cfg.reference()
    v = PlanarVehicle()
    assert isinstance(v, VehicleModel)
    gains = load_profile("sim-planar").default
    for name, g in zip(load_profile("sim-planar").names, gains):
        v.set_param(name, g)
    init = np.array([0.0, 0.4, 1.0, -0.3, 0.0, 0.0])
    roll = simulate(gains, init)
    st = v.reset(pos=np.array([0.0, 0.0, -1.0]), vel=np.array([0.4, 0.0, 0.3]))
    assert st.pos.tolist() == [0.0, 0.0, -1.0]
    for k in range(cfg.steps):
        r = refs[k]
        st = v.step(Setpoint(pos=np.array([r[0], 0.0, -r[2]]), vel=np.array([r[1], 0.0, -r[3]])))
        assert np.array_equal(v.planar_state, roll.states[0, k + 1])
        assert np.array_equal(st.thrust, roll.inputs[0, k])
    # NED mapping: north = x, down = -z, pitch = -theta.
    x, vx, z, vz, th, om = roll.states[0, -1]
    assert st.pos.tolist() == [x, 0.0, -z] and st.vel.tolist() == [vx, 0.0, -vz] and st.rpy[1] == -th


def test_planar_vehicle_reports_crash_codes():
    v = PlanarVehicle()
    v.set_param("FENCE_X_MAX", 0.5)
    v.reset(pos=np.array([0.0, 0.0, -1.0]), vel=np.array([2.0, 0.0, 0.0]))
    codes = [v.step(Setpoint(pos=np.array([0.0, 0.0, -1.0]))).crashed for _ in range(50)]
    assert codes[0] == 0 and 1 in codes and v.fence_codes == (1, 3)
    # No pitch damping and a stiff pitch loop: the attitude diverges past 85 degrees (code 4, EMERGENCY).
    v = PlanarVehicle()
    v.set_param("ATT_PIT_D", 0.0)
    v.set_param("ATT_PIT_P", 1.5e5)
    v.reset(pos=np.array([0.0, 0.0, -1.0]))
    states = [v.step(Setpoint(pos=np.array([0.5, 0.0, -1.0]))) for _ in range(100)]
    crashed = [s for s in states if s.crashed]
    assert crashed and crashed[0].crashed == 4 and crashed[0].crash_reason == "pitch beyond tilt limit"


@pytest.mark.parametrize("value", [0, 1, -1, 5, 1000, 2**31 - 1, -(2**31)])
def test_int32_encodings_round_trip(value):
    for enc in ("c_cast", "bytewise"):
        if enc == "c_cast" and abs(value) > 2**24:
            continue  # C-cast is exact to 24 bits only (fact sheet 2)
        wire = np.float32(encode_int(value, enc)).item()  # what a float32 field carries
        assert decode_int(wire, enc) == value
    assert encode_int(5, "bytewise") != 5.0  # PX4 symptom of a mismatch: 5 reads as a denormal float


def test_param_table_refusals_and_float32_storage(tmp_path):
    applied = {}
    specs = [ParamSpec("A", 0.1, 0.0, 1.0), ParamSpec("B", 2, 0, 10, "INT32"), ParamSpec("R", 1, 0, 1, "INT32")]
    t = ParamTable(specs, applied.__setitem__, "c_cast", readonly=("R",), path=tmp_path / "p.param")
    assert applied["A"] == np.float32(0.1)  # the owner flies the stored float32 value from the start
    assert t.set_local("A", 2.0) and t.set_local("A", float("nan")) and t.set_local("R", 0)
    assert t.set_local("B", 3.6) is None and t["B"] == 3.0 == applied["B"]
    text = (tmp_path / "p.param").read_text()
    assert "B 3" in text and "R " not in text
    t2 = ParamTable(specs, {}.__setitem__, "c_cast", readonly=("R",), path=tmp_path / "p.param")
    assert t2["B"] == 3.0


def test_personality_modes():
    assert OURS.custom_mode(Mode.GUIDED) == 4 and OURS.decode_mode(9) is Mode.LAND
    assert PX4.mode_from_command(6, 0) is Mode.GUIDED and PX4.custom_mode(Mode.GUIDED) == 393216
    assert PX4.mode_from_command(4, 6) is Mode.LAND and PX4.encoding == "bytewise"
    assert ARDUPILOT.capabilities & (16 | 131072) == 0  # ArduPilot declares no encoding bit
    assert OURS.capabilities & 131072 and PX4.capabilities & 16


def test_estimator_exact_and_noisy():
    est = Estimator(0.02)
    p, v = est.update(np.array([1.0, 2.0, 3.0]), np.array([0.1, 0.2, 0.3]), np.zeros(3))
    assert p.tolist() == [1.0, 2.0, 3.0] and v.tolist() == [0.1, 0.2, 0.3]
    est.configure(0.05, 0.05, 0.5)
    est.reset(np.zeros(3), np.zeros(3))
    errs = [est.update(np.zeros(3), np.zeros(3), np.zeros(3))[0] for _ in range(500)]
    # The estimate is noisy but the filter beats the raw position sensor (std 0.05).
    assert 0 < np.std(errs) < 0.05


def test_ardupilot_style_echo_uses_index_65535():
    """ArduPilot answers PARAM_SET with param_index -1, i.e. 65535 in PARAM_VALUE's uint16 field."""

    class Msg:
        param_id, param_value = "A", 0.5

        def get_type(self):
            return "PARAM_SET"

    sent = []
    t = ParamTable([ParamSpec("A", 0.1, 0.0, 1.0)], lambda n, v: None, "c_cast", echo_index=False)
    t.send = lambda name, index: sent.append((name, index))
    t.handle(Msg())
    assert sent == [("A", 65535)] and t["A"] == np.float32(0.5)


@pytest.mark.parametrize("personality", [PX4, ARDUPILOT])
def test_offboard_position_setpoint_above_lifts_off_on_px4_only(personality):
    """PX4 takes off when armed in OFFBOARD with a position setpoint above it (the tuner's PX4 path); ArduPilot
    needs NAV_TAKEOFF in GUIDED and stays on the ground."""
    from ksbo_sim.mavlink.flight import Flight

    model = PlanarVehicle()
    fl = Flight(model, Estimator(model.ctrl_dt), lambda sev, text: None)
    fl.takeoff_mode, fl.after_takeoff_mode = personality.takeoff_mode, personality.after_takeoff_mode
    assert fl.set_mode(Mode.GUIDED) is None and fl.arm() is None
    nan3 = np.full(3, np.nan)
    t = 0
    for _ in range(200):
        fl.set_target(np.array([0.0, 0.0, -1.0]), nan3, nan3, t)
        fl.step(t)
        t += fl.dt_us
    if personality is PX4:
        assert not fl.landed and fl.truth.pos[2] < -0.5
    else:
        assert fl.landed and fl.truth.pos[2] == 0.0
