"""Parameter encodings and the stack / name-generation mapping (unit tests on parameter tables)."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from ksbo_mav.errors import InputError, VehicleError
from ksbo_mav.mav.params import Param
from ksbo_mav.mav.params.encoding import decode, encode, same_value
from ksbo_mav.mav.stacks import (ARDUPILOT, ARDUPILOT_LEGACY, KSBO_SIM, PX4, GainMap, Identity,
                                 ardupilot_generation, default_profile, detect_stack)
from ksbo_mav.profiles import load_profile


def test_int32_encodings_per_autopilot():
    # PX4 (bytewise): the int's bytes inside the float; an INT32 of 5 read C-cast shows as 7e-45, and the
    # famous mismatch symptom (PX4#19274) is the reverse: float 5.0's bits read as int = 1084227584.
    wire = encode(5, 6, "bytewise")
    assert struct.pack("<f", wire) == struct.pack("<i", 5)
    assert decode(wire, 6, "bytewise") == 5
    assert decode(5.0, 6, "bytewise") == 1084227584
    assert encode(-1, 6, "bytewise") != -1.0 and decode(encode(-1, 6, "bytewise"), 6, "bytewise") == -1
    # ArduPilot (C-cast): the value itself, rounded to an integer.
    assert encode(5, 6, "c_cast") == 5.0 and decode(5.0, 6, "c_cast") == 5
    assert encode(2.6, 4, "c_cast") == 3.0
    # REAL32 is never re-encoded.
    assert encode(0.15, 9, "bytewise") == 0.15 and decode(0.15, 9, "bytewise") == 0.15
    assert same_value(0.15, float(np.float32(0.15)), 9) and not same_value(0.15, 0.16, 9)
    assert same_value(3.0, 3.4, 6) and not same_value(3.0, 4.0, 6) and not same_value(np.nan, np.nan, 9)


def _table(values: dict[str, float]) -> dict[str, Param]:
    return {n: Param(n, v, 9, i) for i, (n, v) in enumerate(values.items())}


# The same physical gains, as each stack / generation stores them (fact sheet 3.1-3.3).
GAINS = {"ne_pos_p": 1.3, "ne_vel_p": 2.5, "ne_vel_i": 0.6, "ne_vel_d": 0.2, "d_pos_p": 1.4, "d_vel_p": 4.5}
AP_NEW = {"PSC_NE_POS_P": 1.3, "PSC_NE_VEL_P": 2.5, "PSC_NE_VEL_I": 0.6, "PSC_NE_VEL_D": 0.2, "PSC_D_POS_P": 1.4,
          "PSC_D_VEL_P": 4.5, "PSC_D_ACC_P": 0.05, "PSC_NE_VEL_IMAX": 10.0, "ATC_RAT_PIT_P": 0.135}
AP_LEGACY = {"PSC_POSXY_P": 1.3, "PSC_VELXY_P": 2.5, "PSC_VELXY_I": 0.6, "PSC_VELXY_D": 0.2, "PSC_POSZ_P": 1.4,
             "PSC_VELZ_P": 4.5, "PSC_ACCZ_P": 0.5, "PSC_VELXY_IMAX": 1000.0, "ATC_RAT_PIT_P": 0.135}
PX4_TABLE = {"MPC_XY_P": 1.3, "MPC_XY_VEL_P_ACC": 2.5, "MPC_XY_VEL_I_ACC": 0.6, "MPC_XY_VEL_D_ACC": 0.2,
             "MPC_Z_P": 1.4, "MPC_Z_VEL_P_ACC": 4.5, "MC_PITCH_P": 6.5}


def _canonical(profile) -> list[str]:
    return [str(g.extra["canonical"]) for g in profile.gains]


def test_both_ardupilot_generations_and_px4_map_to_the_same_gain_vector():
    ap, px4 = load_profile("ardupilot-copter"), load_profile("px4-copter")
    assert _canonical(ap) == _canonical(px4)  # one gain vector, two stacks
    want = np.array([GAINS[c] for c in _canonical(ap)])
    maps = {
        "new": GainMap.build(ap.names, ARDUPILOT, _table(AP_NEW), ap),
        "legacy": GainMap.build(ap.names, ARDUPILOT, _table(AP_LEGACY), ap),
        "px4": GainMap.build(px4.names, PX4, _table(PX4_TABLE), px4),
    }
    assert maps["new"].generation == "new" and maps["legacy"].generation == "legacy"
    assert maps["legacy"].param_names[:2] == ("PSC_POSXY_P", "PSC_VELXY_P")
    for name, table in (("new", AP_NEW), ("legacy", AP_LEGACY), ("px4", PX4_TABLE)):
        x = maps[name].from_params(table)
        np.testing.assert_allclose(x, want, err_msg=name)
        back = maps[name].to_params(x)  # and the way back writes the stack's own names and units
        assert back == pytest.approx({n: table[n] for n in maps[name].param_names})


def test_legacy_scale_factors_of_rescaled_parameters():
    # Parameters whose units changed in PR #31513: new value = legacy value * scale.
    prof_names = ["PSC_D_ACC_P", "PSC_NE_VEL_IMAX", "PSC_D_ACC_IMAX"]
    gm = GainMap.build(prof_names, ARDUPILOT, _table({"PSC_POSXY_P": 1, "PSC_ACCZ_P": 0.5, "PSC_VELXY_IMAX": 1000,
                                                      "PSC_ACCZ_IMAX": 800}))
    assert gm.param_names == ("PSC_ACCZ_P", "PSC_VELXY_IMAX", "PSC_ACCZ_IMAX")
    np.testing.assert_allclose(gm.from_params({"PSC_ACCZ_P": 0.5, "PSC_VELXY_IMAX": 1000, "PSC_ACCZ_IMAX": 800}),
                               [0.05, 10.0, 0.8])
    assert gm.to_params(np.array([0.05, 10.0, 0.8])) == pytest.approx(
        {"PSC_ACCZ_P": 0.5, "PSC_VELXY_IMAX": 1000.0, "PSC_ACCZ_IMAX": 800.0})
    assert len(ARDUPILOT_LEGACY) == len({old for old, _ in ARDUPILOT_LEGACY.values()})


def test_unknown_or_ambiguous_vehicles_are_refused():
    with pytest.raises(VehicleError, match="generation"):
        ardupilot_generation({"PSC_NE_POS_P", "PSC_POSXY_P"})
    with pytest.raises(VehicleError, match="generation"):
        ardupilot_generation({"ATC_RAT_PIT_P"})
    with pytest.raises(VehicleError, match="no parameter MPC_XY_P"):
        GainMap.build(["MPC_XY_P"], PX4, _table({"MC_PITCH_P": 1.0}))
    with pytest.raises(VehicleError, match="unsupported autopilot"):
        detect_stack(Identity(1, 1, autopilot=8, vehicle_type=2))
    with pytest.raises(VehicleError, match="unsupported autopilot"):
        detect_stack(Identity(1, 1, autopilot=0, vehicle_type=2, vendor_id=0))  # generic, not ours
    with pytest.raises(InputError):
        GainMap.build(["PSC_NE_POS_P"], ARDUPILOT, _table(AP_NEW)).to_params(np.zeros(2))


def test_stack_detection_modes_and_default_profiles():
    sim = Identity(1, 1, 0, 2, vendor_id=0x4B53, product_id=1)
    assert detect_stack(sim) is KSBO_SIM and default_profile(sim, KSBO_SIM) == "sim-planar"
    ap = Identity(1, 1, 3, 2, flight_sw_version=(4 << 24) | (7 << 16) | 0)
    assert detect_stack(ap) is ARDUPILOT and ap.firmware == "4.7.0-dev"
    assert default_profile(ap, ARDUPILOT) == "ardupilot-copter"
    assert detect_stack(Identity(1, 1, 12, 2)) is PX4 and PX4.encoding == "bytewise" and ARDUPILOT.encoding == "c_cast"
    # DO_SET_MODE: ArduPilot p2 = custom mode; PX4 p2 = main mode, p3 = sub mode (OFFBOARD = 6<<16).
    assert ARDUPILOT.mode_params(ARDUPILOT.modes["guided"]) == (1.0, 4.0, 0.0)
    assert PX4.mode_params(PX4.modes["guided"]) == (1.0, 6.0, 0.0)
    assert PX4.mode_params(PX4.modes["hold"]) == (1.0, 4.0, 3.0)  # AUTO.LOITER


def test_trust_region_is_absolute_and_baseline_relative():
    from ksbo_mav.mav.gains import trust_region

    ap = load_profile("ardupilot-copter")  # max_step_fraction 0.5, max_ratio 2
    base = ap.default
    lo, hi = trust_region(ap, base)
    b = ap.bounds
    assert np.all(lo >= b[:, 0]) and np.all(hi <= b[:, 1]) and np.all(lo <= base) and np.all(base <= hi)
    pos = base > 0
    assert np.all(lo[pos] >= base[pos] / 2 - 1e-12) and np.all(hi[pos] <= base[pos] * 2 + 1e-12)
    assert np.all(hi - base <= 0.5 * (b[:, 1] - b[:, 0]) + 1e-12)
    planar = load_profile("sim-planar")  # no ratio: zero baselines (I gains) may still grow
    lo, hi = trust_region(planar, planar.default)
    assert hi[1] == pytest.approx(0.25) and lo[1] == 0.0
