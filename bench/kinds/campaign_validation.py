"""A finished campaign's validation and real-time figures (the campaign cell's ``validation`` analysis): flights by
label and outcome, the training figure-8's lap-2 RMS of the baseline and the confirmation, whether the tool kept
real time (how late its setpoints went out, how often LOCAL_POSITION_NED arrived, per trial), the validation
flights' verdict per manoeuvre (the campaign's own rule, ``ksbo_mav.campaign.verdict``) and the peak lean of the
position steps (the training trial's step, the validation's step flights)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np


def peak_lean_deg(tlog: str | Path) -> float | None:
    """The largest lean (deg, acos(cos roll cos pitch) of the vehicle's ATTITUDE) of a validation flight's tlog,
    from its start marker to its end marker (or the log's end); None without ATTITUDE there or a readable log."""
    from ksbo_mav.errors import InputError
    from ksbo_mav.mav.tlog import read_tlog
    from ksbo_task.limit_checks import tilt_rad

    try:
        records = read_tlog(tlog)
    except InputError:
        return None
    peak, inside = None, False
    for r in records:
        kind = r.msg.get_type()
        if r.sent and kind == "STATUSTEXT":
            text = str(r.msg.text)
            inside = inside or text.startswith("ksbo val start")
            if text.startswith("ksbo val end"):
                break
        elif inside and not r.sent and kind == "ATTITUDE":
            lean = math.degrees(tilt_rad(r.msg.roll, r.msg.pitch))
            peak = lean if peak is None else max(peak, lean)
    return peak


def search_end(s: dict | None) -> str:
    """"early stop after 5 of 10" or "budget 10 flown"."""
    if not s:
        return "–"
    return f"early stop after {s['after']} of {s['budget']}" if s.get("stopped") else f"budget {s['budget']} flown"


def verdicts(entries: list) -> dict[str, dict[str, dict[str, Any]]]:
    """{pair: {manoeuvre: the judged figures}} of the validation journal's entries."""
    from ksbo_mav.campaign.verdict import judge_pairs

    out = {}
    for pv in judge_pairs(entries):
        out[pv.pair] = {m: {"verdict": j.verdict, "metric": j.metric, "base": list(j.base), "cand": list(j.cand),
                            "spread": j.spread, "diff": j.diff, "base_aborted": j.base_aborted,
                            "cand_aborted": j.cand_aborted} for m, j in pv.judged.items()}
    return out


def figures(d: Path) -> dict[str, Any]:
    from ksbo_mav.campaign.validation_log import ValidationJournal

    res = json.loads((d / "result.json").read_text()) if (d / "result.json").exists() else {}
    trials = [json.loads(p.read_text()) for p in sorted((d / "trials").glob("trial_*.json"))]
    by_label: dict[str, list[dict]] = {}
    for t in trials:
        by_label.setdefault(t["label"], []).append(t)

    def rms(ts: list[dict]) -> list[float]:
        return [t["score"]["rms_lap2_m"] for t in ts if t["score"].get("rms_lap2_m") is not None]

    lags = [t["link"]["lag_max_ms"] for t in trials if t.get("link", {}).get("lag_max_ms") is not None]
    late = [t["link"]["late_fraction"] for t in trials if t.get("link", {}).get("late_fraction") is not None]
    rates = [t["score"]["rate_hz"] for t in trials if t["score"].get("rate_hz")]
    path = d / "validation.jsonl"
    entries = ValidationJournal(path).entries if path.exists() else []
    cfg = json.loads((d / "campaign.json").read_text()).get("config", {})
    trial_leans = {k: [t["step"].get("peak_lean_deg") for t in ts if t.get("step")] for k, ts in by_label.items()}
    step_leans: dict[str, list[float | None]] = {}
    for e in entries:
        if e.manoeuvre == "steps" and e.pair == "recommendation" and e.tlog:
            step_leans.setdefault(e.gains, []).append(peak_lean_deg(e.tlog))
    base_x = res.get("baseline", {}).get("x")
    return {
        "figure8": "on board" if any(t.get("trajectory", {}).get("on_board") for t in trials) else "streamed",
        "flights_by_label": {k: len(v) for k, v in by_label.items()},
        "outcomes": {o: sum(t["outcome"] == o for t in trials) for o in sorted({t["outcome"] for t in trials})},
        "search_end_text": search_end(res.get("search_end")),
        "baseline_rms": rms([t for t in trials if base_x is not None and np.allclose(t["gains"], base_x)]),
        "confirm_rms": rms(by_label.get("confirm", [])),
        "lag_max_ms": max(lags) if lags else None, "late_fraction_max": max(late) if late else None,
        "rate_hz_min": min(rates) if rates else None,
        "validation_flights": len(entries),
        "validation_wall_s": round(sum(e.ended_unix - e.started_unix for e in entries
                                       if e.ended_unix and e.started_unix), 1),
        "validation_outcomes": {o: sum(e.outcome.value == o for e in entries)
                                for o in sorted({e.outcome.value for e in entries})},
        "verdicts": verdicts(entries), "trial_step": bool(cfg.get("trial_step")),
        "trial_step_leans": {k: v for k, v in trial_leans.items() if v},
        "trial_step_aborts": sum(t["outcome"] == "tilt" and t["message"].startswith("position step") for t in trials),
        "validation_step_leans": step_leans,
    }
