"""The wind-campaigns sweep's figures (ksbo_bench.kinds.campaign_wind, the ``validation`` analysis' flights that
did not complete): the wind's direction from either stack's SITL parameters, a flipped sign noticed, the validation
flights counted per manoeuvre with the vehicle's message, and the page built from such records."""

from __future__ import annotations

import json

from ksbo_bench.kinds import campaign_wind as cw
from ksbo_bench.kinds.campaign_analyses import ANALYSES
from ksbo_bench.kinds.campaign_validation import figures
from ksbo_bench.report.wind_campaigns import report

from ksbo_mav.campaign.validation_log import ValidationEntry
from ksbo_mav.mav.outcome import TrialOutcome


def test_the_wind_set_is_where_it_comes_from_on_both_stacks():
    # PX4 SIH flies v_apparent = v + wind: the vector points where the wind comes from
    assert cw.wind_set({"SIH_WIND_N": 3.54, "SIH_WIND_E": 3.54}) == {"mps": 5.01, "from_deg": 45.0}
    assert cw.wind_set({"SIH_WIND_N": -2.0, "SIH_WIND_E": 0.0})["from_deg"] == 180.0
    assert cw.wind_set({"SIM_WIND_SPD": 5.0, "SIM_WIND_DIR": 45.0}) == {"mps": 5.0, "from_deg": 45.0}
    assert cw.wind_set({}) is None and cw.wind_set({"SIM_WIND_SPD": 0.0}) is None


def _entry(k: int, kind: str, rms: float, frm: float | None = 45.0) -> dict:
    cond = {} if frm is None else {"wind_inferred_mps": 5.0, "wind_inferred_from_deg": frm}
    return {"trial": k, "kind": kind, "outcome": "ok", "rms": rms, "cond": cond}


def test_a_flipped_wind_sign_is_noticed(tmp_path):
    entries = [_entry(0, "opt", 1.0), _entry(1, "opt", 0.5), _entry(2, "confirm", 0.4)]
    (tmp_path / "journal.jsonl").write_text("".join(json.dumps(e) + "\n" for e in entries))
    key = {"vehicle": "px4", "sitl_params": {"SIH_WIND_N": 3.54, "SIH_WIND_E": 3.54}, "tune_args": ["--budget", "3"]}
    result: dict = {}
    ANALYSES["wind"](key, tmp_path, result)
    assert result["wind"]["sign_ok"] and result["wind"]["inferred_from_deg"] == 45 and result["wind"]["flights"] == 3
    assert "wind_preflight" not in result  # no --wind declared
    flipped = [_entry(0, "opt", 1.0, frm=225.0)]
    assert cw.wind_check(flipped, key["sitl_params"])["sign_ok"] is False
    assert cw.wind_check([_entry(0, "opt", 1.0, frm=None)], {}) is None  # calm and not inferred: nothing to say


def test_tune_wind_is_read_from_the_arguments():
    assert cw.tune_wind(["--budget", "3", "--wind", "5"]) == 5.0 and cw.tune_wind(["--wind=2.5"]) == 2.5
    assert cw.tune_wind(["--budget", "3"]) is None


def _flight(n: int, m: str, gains: str, outcome: str, metrics: dict, message: str = "") -> str:
    return ValidationEntry(flight=n, manoeuvre=m, pair="recommendation", gains=gains, x=(1.0, 2.0),
                           outcome=TrialOutcome(outcome), metrics=metrics, tlog=f"validation/flight_{n:03d}.tlog",
                           restored=True, message=message).to_json()


def test_validation_flights_a_manoeuvre_the_vehicle_did_not_fly_and_the_page(tmp_path):
    lines = [_flight(0, "hold", "baseline", "ok", {"hold_rms_m": 0.07}),
             _flight(1, "hold", "recommendation", "ok", {"hold_rms_m": 0.03}),
             _flight(2, "hold", "baseline", "ok", {"hold_rms_m": 0.06}),
             _flight(3, "hold", "recommendation", "ok", {"hold_rms_m": 0.04}),
             _flight(4, "auto_mission", "baseline", "error", {}, "vehicle did not enter mode AUTO.MISSION")]
    (tmp_path / "validation.jsonl").write_text("\n".join(lines) + "\n")
    (tmp_path / "campaign.json").write_text(json.dumps({"config": {}}))
    v = figures(tmp_path)
    assert v["validation_by_manoeuvre"] == {"hold": 4, "auto_mission": 1} and v["validation_flights"] == 5
    assert v["validation_not_completed"] == [{"manoeuvre": "auto_mission", "gains": "baseline", "outcome": "error",
                                              "message": "vehicle did not enter mode AUTO.MISSION"}]
    assert v["verdicts"]["recommendation"]["hold"]["verdict"] == "better"
    rec = {"key": {"label": "default", "vehicle": "px4", "build": "px4-main", "speedup": 1.0, "seed": 0},
           "status": "ok", "flights": {"total": 7, "reflown": 6},
           "safety": {"unsafe": 0, "aborted": 0, "crashed": 0, "interrupted": 0},
           "result": {**v, "rms_per_flight": [1.0, 0.5, 0.4], "confirm_rms": [0.4, 0.2],
                      "reflown": {"baseline": [1.0, 1.1, 0.9], "rec": [0.3, 0.32, 0.28]}, "cut": 0.7}}
    page = report([json.loads(json.dumps(rec))])
    assert "| PX4 SITL px4-main x1 (default) | 7 + 5 validation + 6 re-flown | 0 / 0 / 0 / 0 | 1.000 → 0.300 (-70 %) " \
           "| 1.000 ± 0.100 (3) | 0.300 ± 0.020 (3) | -70 % |" in page
    assert "| recommendation | hold | 4 | better | hold_rms_m 0.065 → 0.035" in page
    assert "| auto_mission | 1 |" in page and "vehicle did not enter mode AUTO.MISSION" in page
