"""Profiles: typed tables that refuse keys nothing reads (naming the key and the file), shipped profiles load."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest

from ksbo_mav.errors import InputError
from ksbo_mav.profiles import (SECTIONS, MissionSpec, SafetyLimits, ScoreSpec, TrustRegion, available_profiles,
                               load_profile)

PARAMS = Path(__file__).resolve().parents[1] / "params"


def _variant(tmp_path: Path, base: str, old: str, new: str) -> Path:
    text = (PARAMS / f"{base}.toml").read_text()
    assert old in text
    p = tmp_path / f"{base}-variant.toml"
    p.write_text(text.replace(old, new, 1))
    return p


@pytest.mark.parametrize("name", ["sim-planar", "ardupilot-copter", "px4-copter"])
def test_shipped_profiles_load_with_typed_tables(name):
    assert name in available_profiles()
    p = load_profile(name)
    assert isinstance(p.safety, SafetyLimits) and isinstance(p.trust_region, TrustRegion)
    assert isinstance(p.mission_spec, MissionSpec) and isinstance(p.score_spec, ScoreSpec)
    # The dict view (read by ksbo_mav.mav and tune) holds exactly what the file sets, with the typed values.
    for table, obj in (("safety", p.safety), ("trust_region", p.trust_region), ("mission", p.mission_spec)):
        for key, value in p.section(table).items():
            assert getattr(obj, key) == value
    assert p.section("nonexistent") == {}


def test_typed_values_of_the_shipped_profiles():
    ap, planar = load_profile("ardupilot-copter"), load_profile("sim-planar")
    assert (ap.safety.x_max_m, ap.safety.y_max_m, ap.safety.z_min_m, ap.safety.z_max_m) == (15, 8, 4, 16)
    assert ap.trust_region == TrustRegion(max_step_fraction=0.5, max_ratio=2.0)
    assert ap.mission_spec.type == "figure8-ne" and ap.mission_spec.scale_east == 2.5 and ap.frame == "quad-3d"
    assert math.isinf(planar.safety.y_max_m) and planar.trust_region.max_ratio is None
    assert planar.mission_spec.scale_east == planar.mission_spec.scale_m == 0.75 and planar.frame == "planar-xz"
    assert planar.score_spec.given() == {}


def test_planar_profile_limits_are_the_in_process_monitors():
    """One set of limits for the planar task: a MAVLink flight of the built-in vehicle trips where the in-process
    monitor trips (same limits and logic), inside the environment bounds the simulator crashes at."""
    from ksbo_mav.mav.monitor import limits_from_profile
    from ksbo_task.limit_checks import MonitorLimits, planar_monitor_limits

    lim = limits_from_profile(load_profile("sim-planar"))
    assert lim == planar_monitor_limits()
    env = MonitorLimits()  # the task's environment bounds
    assert lim.x_max < env.x_max and env.z_min < lim.z_min < lim.z_max < env.z_max
    assert lim.tilt_max_deg < env.tilt_max_deg and lim.brake_accel == 3.0


def test_typed_defaults_match_what_the_client_uses():
    from ksbo_mav.mav.mission import Mission
    from ksbo_mav.mav.monitor import limits_from_profile

    for name in ("sim-planar", "ardupilot-copter"):
        p = load_profile(name)
        lim, s = limits_from_profile(p), p.safety
        assert (lim.x_max, lim.y_max, lim.z_min, lim.z_max, lim.tilt_max_deg, lim.tracking_error_max) == (
            s.x_max_m, s.y_max_m, s.z_min_m, s.z_max_m, s.tilt_max_deg, s.tracking_error_max_m)
        assert limits_from_profile(p, {"x_max_m": 0.5}).x_max == 0.5
        m, ms = Mission.from_profile(p), p.mission_spec
        assert (m.kind, m.scale, m.scale2, m.period, m.center_up, m.laps, m.rate_hz) == (
            ms.type, ms.scale_m, ms.scale_east, ms.period_s, ms.center_up_m, ms.laps, ms.rate_hz)


@pytest.mark.parametrize("base,old,new,words", [
    ("sim-planar", "x_max_m = 1.6", "x_max = 2.0", ["'x_max'", "[safety]", "x_max_m"]),  # typo in [safety]
    ("sim-planar", "max_step_fraction = 0.5", "max_step = 0.5", ["'max_step'", "[trust_region]"]),
    ("sim-planar", "period_s = 6.0", "period = 6.0", ["'period'", "[mission]"]),
    ("ardupilot-copter", "[score]\n", "[score]\nmetric = \"rms\"\n", ["'metric'", "[score]", "unsafe_rms_ratio"]),
    ("ardupilot-copter", 'frame = "quad-3d"', 'frame = "quad-3d"\nparam_encoding = "c_cast"',
     ["'param_encoding'", "[vehicle]"]),
    ("sim-planar", "[safety]", "[generations]\nA = 1\n\n[safety]", ["[generations]"]),
    ("sim-planar", 'scg = 0.4', 'scg = 0.4\ndefualt = 0.3', ["POS_X_P", "'defualt'"]),  # one row only
    ("sim-planar", 'scg = 0.4', 'scg = 0.4\nlegacy_nme = "X"', ["POS_X_P", "'legacy_nme'"]),
])
def test_unknown_keys_are_refused_naming_the_key_and_the_file(tmp_path, base, old, new, words):
    path = _variant(tmp_path, base, old, new)
    with pytest.raises(InputError) as exc:
        load_profile(path)
    msg = str(exc.value)
    assert str(path) in msg and "\n" not in msg
    for w in words:
        assert w in msg


@pytest.mark.parametrize("old,new,words", [
    ("x_max_m = 1.6", 'x_max_m = "2"', ["x_max_m", "a number"]),
    ("x_max_m = 1.6", "x_max_m = -1.0", ["x_max_m", "positive"]),
    ("z_max_m = 1.8", "z_max_m = -1.0", ["z_min_m", "z_max_m"]),
    ("max_step_fraction = 0.5", "max_step_fraction = 0.0", ["max_step_fraction"]),
    ("laps = 2", "laps = 2.5", ["laps", "whole number"]),
    ("rate_hz = 50", "rate_hz = 30", ["rate_hz", "1000"]),
    ('type = "figure8-xz"', 'type = "circle"', ["circle", "figure8-ne"]),
    ('frame = "planar-xz"', 'frame = "hexa"', ["hexa", "quad-3d"]),
    ("backup_covers_trials = false", "backup_covers_trials = 1", ["backup_covers_trials", "true or false"]),
    ("laps = 2", "laps = 2\nlead_in_s = 1.0", ["lead_in_s", "figure8-ne"]),
])
def test_bad_values_are_refused(tmp_path, old, new, words):
    path = _variant(tmp_path, "sim-planar", old, new)
    with pytest.raises(InputError) as exc:
        load_profile(path)
    for w in words:
        assert w in str(exc.value)


def test_score_keys_are_the_fields_of_one_dataclass(tmp_path):
    path = _variant(tmp_path, "ardupilot-copter", "unsafe_rms_ratio = 2.0\n",
                    "unsafe_rms_ratio = 3.0\nrms_ref_m = 0.2\n")
    p = load_profile(path)
    assert p.score_spec.rms_ref_m == 0.2 and p.section("score") == {"unsafe_rms_ratio": 3.0, "rms_ref_m": 0.2,
                                                                      "smooth_weight": 0.5, "rough_cutoff_hz": 2.0,
                                                                      "rough_band": 0.15}
    score = "[score]\nQ = [1, 0.1, 1, 0.1, 0.1, 0.1]\nj_hi = 5\n\n[mission]"
    path = _variant(tmp_path, "sim-planar", "[mission]", score)
    assert load_profile(path).score_spec.given() == {"Q": (1.0, 0.1, 1.0, 0.1, 0.1, 0.1), "j_hi": 5.0}
    assert set(SECTIONS) == {"trust_region", "safety", "mission", "score", "campaign", "validation"}


def test_cli_reports_a_bad_profile_in_one_line(tmp_path):
    path = _variant(tmp_path, "sim-planar", "x_max_m = 1.6", "x_maxm = 2.0")
    out = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "evaluate", "--profile", str(path)],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2 and out.stdout == ""
    assert out.stderr.count("\n") == 1 and "'x_maxm'" in out.stderr and str(path) in out.stderr


def test_unknown_safety_override_is_refused():
    from ksbo_mav.errors import InputError
    from ksbo_mav.mav.monitor import limits_from_profile

    with pytest.raises(InputError, match="unknown safety override 'x_max'"):
        limits_from_profile(load_profile("sim-planar"), {"x_max": 0.5})


def test_backup_coverage_implies_backup_exploration_for_ksbo_adaptive_only(tmp_path):
    """The copter profiles (outer loops behind a lean-angle limit) let ksbo-adaptive explore beyond the
    certified set; the planar task (attitude loop tuned) does not; the user's option wins either way."""
    from ksbo_mav.campaign.config import COVERED_TRIALS, optimizer_options, profile_defaults

    planar, ap, px4 = (load_profile(n) for n in ("sim-planar", "ardupilot-copter", "px4-copter"))
    assert not planar.safety.backup_covers_trials and ap.safety.backup_covers_trials and px4.safety.backup_covers_trials
    implied = COVERED_TRIALS
    assert implied["backup_beta"] == 0.5 and implied["tr_success"] == 1  # wider certificate, faster trust region
    assert profile_defaults("ksbo-adaptive", ap) == profile_defaults("ksbo-adaptive", px4) == implied
    assert profile_defaults("ksbo-adaptive", planar) == {} and profile_defaults("ksbo", ap) == {}
    assert profile_defaults("ksbo-adaptive", None) == {}
    assert optimizer_options("local", {}, "ksbo-adaptive", ap)["backup_beta"] == 0.5
    assert optimizer_options("local", {"backup_beta": 2.0}, "ksbo-adaptive", ap)["backup_beta"] == 2.0
    assert "backup_beta" not in optimizer_options("sim", {}, "ksbo-adaptive", planar)
    flipped = _variant(tmp_path, "sim-planar", "backup_covers_trials = false", "backup_covers_trials = true")
    assert profile_defaults("ksbo-adaptive", load_profile(flipped)) == COVERED_TRIALS


def test_px4_search_box_reaches_the_position_gain_that_halves_the_sitl_error():
    """On PX4 SITL MPC_XY_P 1.9 alone (2x the 0.95 default) takes the lap-2 RMS from ~1.4 m to ~0.73 m;
    the default search box (profile box ∩ trust region around the defaults) must reach it, and the trust region
    still caps every gain at twice / half its default."""
    import numpy as np

    from ksbo_mav.mav.gains import opt_bounds

    px4 = load_profile("px4-copter")
    box = opt_bounds(px4, np.asarray(px4.default, dtype=float))
    i = px4.names.index("MPC_XY_P")
    assert box[i, 1] == pytest.approx(1.9, rel=1e-6)
    assert np.all(box[:, 1] <= 2 * np.asarray(px4.default) * (1 + 1e-9))
    assert np.all(box[:, 0] >= np.asarray(px4.default) / 2 * (1 - 1e-9))


def test_a_profile_extends_a_shipped_one_and_overrides_only_what_it_names(tmp_path):
    stock = load_profile("ardupilot-copter")
    f = tmp_path / "my-quad.toml"
    f.write_text('extends = "ardupilot-copter"\n[vehicle]\nname = "my-quad"\n[mission]\nperiod_s = 14.0\n'
                 '[safety]\ntilt_max_deg = 35.0\n')
    mine = load_profile(f)
    assert mine.name == "my-quad" and mine.vehicle["autopilot"] == stock.vehicle["autopilot"]
    assert mine.mission_spec.period_s == 14.0 and mine.mission_spec.scale_m == stock.mission_spec.scale_m
    assert mine.safety.tilt_max_deg == 35.0
    assert mine.safety.x_max_m == stock.safety.x_max_m
    assert [g.name for g in mine.gains] == [g.name for g in stock.gains]
    child = tmp_path / "child.toml"  # a chain through a relative path, then a key the base does not know
    child.write_text('extends = "my-quad.toml"\n[mission]\nlaps = 3\n')
    assert load_profile(child).mission_spec.period_s == 14.0 and load_profile(child).mission_spec.laps == 3
    child.write_text('extends = "my-quad.toml"\n[mission]\nlapz = 3\n')
    with pytest.raises(InputError, match="lapz"):
        load_profile(child)


def test_a_profile_that_extends_itself_or_nothing_known_is_one_clear_error(tmp_path):
    loop = tmp_path / "loop.toml"
    loop.write_text('extends = "loop.toml"\n')
    with pytest.raises(InputError, match="extends itself"):
        load_profile(loop)
    loop.write_text('extends = "no-such-profile"\n')
    with pytest.raises(InputError, match="unknown profile 'no-such-profile'"):
        load_profile(loop)
