"""The fault matrix's and the wind inference's cells read and tabled without flying: their keys are checked, the
parameters off a snapshot are found (the autopilot's own aside), the gains a second connection reads are named,
and each case's newest record is one row of its table in the matrix's order."""

from __future__ import annotations

import pytest

from ksbo_bench.cell_errors import SweepError
from ksbo_bench.kinds import KINDS
from ksbo_bench.kinds.fault_moments import gains_text
from ksbo_bench.report import fault_matrix, wind_inference
from ksbo_mav.mav.params.snapshot import Snapshot


def test_the_keys_are_checked_in_one_line():
    KINDS["fault"].check({"fault": "kill", "phase": "hold", "pilot": True})
    for bad, said in (({"fault": "pull", "phase": "hold", "pilot": True}, "fault must be"),
                      ({"fault": "cut", "phase": "landing", "pilot": True}, "phase must be"),
                      ({"fault": "cut", "phase": "hold", "pilot": "yes"}, "pilot is true or false"),
                      ({"fault": "cut", "phase": "hold"}, "needs pilot")):
        with pytest.raises(SweepError, match=said):
            KINDS["fault"].check(bad)
    KINDS["wind"].check({"speed": 3.0, "shape": "sqrt"})
    with pytest.raises(SweepError, match="shape must be"):
        KINDS["wind"].check({"speed": 3.0, "shape": "gusty"})
    assert KINDS["fault"].resources({}) == KINDS["wind"].resources({}) == {"sitl": 1}


def test_parameters_off_the_snapshot_leave_the_autopilots_own_aside():
    snap = Snapshot(None, {}, "ardupilot", "", "ardupilot-copter", ["PSC_NE_POS_P"],
                    {"PSC_NE_POS_P": (1.0, 9), "ATC_RAT_RLL_P": (0.135, 9), "STAT_RUNTIME": (10.0, 6),
                     "GONE": (3.0, 9)})
    now = {"PSC_NE_POS_P": 1.0000001, "ATC_RAT_RLL_P": 0.2, "STAT_RUNTIME": 99.0}
    assert snap.off(now) == {"ATC_RAT_RLL_P": (0.135, 0.2), "GONE": (3.0, None)}


def test_the_gains_read_are_named_baseline_trial_or_not_read():
    base = {"A": 1.0, "B": 2.0}
    assert gains_text({"A": 1.0, "B": 2.0}, base) == "baseline"
    assert gains_text({"A": 1.5, "B": 2.0}, base) == "trial (1 of 2 off the baseline)"
    assert gains_text({"A": 1.0}, base) == "not read (1 of 2 answered)"


def _fault(fault: str, phase: str, pilot: bool, **result) -> dict:
    res = {"case": f"{fault}-{phase}-{'pilot' if pilot else 'alone'}", "reached": True, "mode_at_fault": "GUIDED",
           "gains_at_fault": "trial (6 of 6 off the baseline)", "trial_gains_after_fault_s": 11.6,
           "vehicle": ["+11.5 s guard tripped", "+11.5 s BRAKE armed", "+11.5 s KSG: link lost",
                       "+13.4 s LOITER armed"],
           "left": {"mode": "LOITER", "armed": True, "height_m": 10.0, "gains": "baseline"}, "tune_exit": -9,
           "tune_said": [], "then": [{"cmd": "restore", "exit": 0, "said": []},
                                     {"cmd": "tune --resume", "exit": 0, "said": []}],
           "result": {"validation": "skipped"}, "params_vs_snapshot": {}, "mission_items_at_end": 1, **result}
    return {"key": {"fault": fault, "phase": phase, "pilot": pilot}, "result": res,
            "run": {"started": "2026-12-07T05:00:00Z"}, "timing": {"case_s": 200, "load_1min": 2.0},
            "flights": {"total": 3, "validation": 0}, "safety": {"interrupted": 1, "crashed": 0}}


def test_the_matrix_has_each_cases_newest_record_in_order():
    old = _fault("kill", "mid-trial", True, params_vs_snapshot={"PSC_NE_POS_P": [1.0, 1.4]})
    recs = [old, _fault("cut", "hold", False, reached=False, note="the hold refused"),
            _fault("kill", "mid-trial", True)]
    rows = fault_matrix.table(recs).splitlines()[2:]
    assert [r.split(" | ")[0] for r in rows] == ["| cut-hold-alone", "| kill-mid-trial-pilot"]
    assert "the hold refused" in rows[0]
    assert "guard tripped +11.5 s" in rows[1] and "+13.4 s: LOITER armed" in rows[1] and "11.6 s" in rows[1]
    assert "`restore` 0, `tune --resume` 0" in rows[1] and "all equal; mission 1 item(s)" in rows[1]
    assert "kill-mid-trial-pilot" in fault_matrix.report(recs).split("## Each case in full")[1]
    lines = fault_matrix.matrix(recs).splitlines()
    assert lines[0] == "| phase | cut, pilot | cut, no pilot | kill, pilot | kill, no pilot |" and len(lines) == 8
    mid = next(x for x in lines if x.startswith("| mid-trial |")).split(" | ")
    assert mid[1] == mid[2] == "not flown yet"
    assert mid[3] == "exit -9 → `restore` 0, `tune --resume` 0; left LOITER armed; params equal"


def test_the_wind_table_says_whether_the_inference_holds_what_blows():
    rec = {"key": {"speed": 5.0, "shape": "sqrt", "from_deg": 45.0},
           "result": {"blows_mps": 2.041, "inferred_median": 2.3, "inferred_min": 1.9, "inferred_max": 2.6,
                      "n_inferred": 3, "error": 0.127, "range_contains": True, "from_min_deg": 40,
                      "from_max_deg": 50, "how": "lean angle"}}
    text = wind_inference.report([rec])
    assert "| 5 from 45° | 0 (sqrt, SITL default) | 2.04 | 1.90–2.60 (median 2.30, 3 trials) | +13% | yes |" in text
    assert "lean angle" in text
