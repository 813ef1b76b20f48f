"""Parameter tables: generations and stacks map to one internal gain vector; profiles and personalities agree."""

import dataclasses

import numpy as np
import pytest

from ksbo_mav.profiles import load_profile
from ksbo_sim.copter3d.params import EQUIVALENT, TABLES, build_gains, param_specs
from ksbo_sim.copter3d.personality import PERSONALITIES, TUNED_FIELDS, int_param_names
from ksbo_sim.vehicle import Setpoint


def _internal(personality, values):
    pos, att = build_gains(personality, values)
    return dataclasses.asdict(pos), dataclasses.asdict(att)


def test_names_are_unique_short_and_defaults_inside_ranges():
    for pers in TABLES:
        specs = param_specs(pers)
        names = [s.name for s in specs]
        assert len(set(names)) == len(names), pers
        for s in specs:
            assert len(s.name) <= 16 and s.min <= s.default <= s.max, s
            assert s.type in ("REAL32", "INT32")


def test_both_ardupilot_generations_default_to_the_same_internal_gains():
    assert _internal("ardupilot", {}) == _internal("ardupilot-legacy", {})


@pytest.mark.parametrize(("new", "old", "new_value", "old_value"), [
    ("PSC_NE_POS_P", "PSC_POSXY_P", 1.7, 1.7),
    ("PSC_NE_VEL_D", "PSC_VELXY_D", 0.4, 0.4),
    ("PSC_NE_VEL_IMAX", "PSC_VELXY_IMAX", 7.0, 700.0),
    ("PSC_D_ACC_P", "PSC_ACCZ_P", 0.03, 0.3),
    ("PSC_D_ACC_I", "PSC_ACCZ_I", 0.2, 2.0),
    ("PSC_D_ACC_IMAX", "PSC_ACCZ_IMAX", 0.5, 500.0),
])
def test_generations_map_one_value_to_the_same_internal_gain(new, old, new_value, old_value):
    a = _internal("ardupilot", {new: new_value})
    b = _internal("ardupilot-legacy", {old: old_value})
    assert a[0] == pytest.approx(b[0]) and a[1] == b[1]
    assert a != _internal("ardupilot", {})  # the parameter really does something


def test_generation_scales_agree_with_the_client():
    stacks = pytest.importorskip("ksbo_mav.mav.stacks")
    new_t = {r.spec.name: r for r in TABLES["ardupilot"]}
    old_t = {r.spec.name: r for r in TABLES["ardupilot-legacy"]}
    for new, (old, scale) in stacks.ARDUPILOT_LEGACY.items():
        assert new in new_t and old in old_t, (new, old)
        if new_t[new].target is not None:
            assert new_t[new].field == old_t[old].field
            assert old_t[old].scale == pytest.approx(new_t[new].scale * scale)
            assert new_t[new].spec.default == pytest.approx(old_t[old].spec.default * scale)


def test_px4_rate_k_multiplies_p_i_d():
    _, att = build_gains("px4", {"MC_ROLLRATE_K": 2.0})
    assert att.rat_p[0] == pytest.approx(0.30) and att.rat_i[0] == pytest.approx(0.4)
    assert att.rat_d[0] == pytest.approx(0.006) and att.rat_p[1] == pytest.approx(0.15)


def test_px4_position_gains_land_on_the_same_fields():
    pos, _ = build_gains("px4", {"MPC_XY_P": 1.3, "MPC_XY_VEL_P_ACC": 2.5, "MPC_Z_VEL_P_ACC": 6.0})
    assert (pos.ne_pos_p, pos.ne_vel_p, pos.d_vel_p) == (1.3, 2.5, 6.0)


@pytest.mark.parametrize(("profile", "personalities"), [
    ("ardupilot-copter", ("ardupilot", "ardupilot-legacy")), ("px4-copter", ("px4",))])
def test_profiles_name_real_parameters_with_matching_defaults(profile, personalities):
    prof = load_profile(profile)
    for g in prof.gains:
        field = g.extra["canonical"]
        for pers in personalities:
            name = g.name if pers != "ardupilot-legacy" else g.extra["legacy_name"]
            assert EQUIVALENT[field][pers] == name
            spec = next(s for s in param_specs(pers) if s.name == name)
            assert spec.default == pytest.approx(g.default)
            assert spec.min <= g.min < g.max <= spec.max, name  # search box inside the parameter range
    assert [g.extra["canonical"] for g in prof.gains] == list(TUNED_FIELDS)


def test_every_personality_has_int32_parameters():
    for pers in TABLES:
        assert int_param_names(pers), pers


def test_personality_data_agrees_with_the_endpoint():
    ep = pytest.importorskip("ksbo_sim.mavlink.personality")
    for name, data in PERSONALITIES.items():
        p = ep.PERSONALITIES[name]
        assert p.autopilot == data["autopilot"]
        assert p.encoding == data["param_encoding"]
        assert p.echo_index == data["param_echo_index"]
        assert p.px4_mode_params == (data["do_set_mode"] == "px4_main_sub")
        for key, mode in (("guided", ep.Mode.GUIDED), ("hold", ep.Mode.HOLD), ("land", ep.Mode.LAND)):
            assert p.decode_mode(data["modes"][key]) is mode, (name, key)


def test_setting_a_gain_in_flight_changes_the_controller():
    from ksbo_sim.copter3d import Copter3D

    v = Copter3D("px4", rotor_drag=0.0)
    v.set_param("MPC_XY_P", 1.5)
    assert v.pos_ctrl.g.ne_pos_p == 1.5
    assert v.get_param("MPC_XY_P") == 1.5
    with pytest.raises(KeyError):
        v.set_param("PSC_NE_POS_P", 1.0)
    assert np.isfinite(v.step(Setpoint()).pos).all()  # all-NaN setpoint = hold
