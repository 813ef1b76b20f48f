"""What a campaign cell records from its campaign folder besides the re-flown RMS (read before the folder is
removed): the validation flights' verdicts, the wind the flights inferred beside the wind the cell set (its sign
checked before a number is written), and with ``tune --wind`` what was decided before takeoff against the lean the
baseline's figure-8s flew.

The wind set by the cell, as the direction it blows *from* (deg, clockwise from north): ArduCopter's
``SIM_WIND_DIR`` is that direction; PX4 SIH flies ``v_apparent = v + wind``, so (``SIH_WIND_N``, ``SIH_WIND_E``)
points to where the wind comes from (docs/firmware.md).
"""

from __future__ import annotations

import json
import math
import statistics
from pathlib import Path
from typing import Any


def wind_set(sitl_params: dict[str, float]) -> dict[str, float] | None:
    """{"mps", "from_deg"} of the wind a cell's SITL parameters set; None in calm air."""
    p = sitl_params or {}
    if p.get("SIM_WIND_SPD"):
        return {"mps": float(p["SIM_WIND_SPD"]), "from_deg": float(p.get("SIM_WIND_DIR", 180.0)) % 360}
    n, e = float(p.get("SIH_WIND_N", 0.0)), float(p.get("SIH_WIND_E", 0.0))
    if n or e:
        return {"mps": round(math.hypot(n, e), 2), "from_deg": round(math.degrees(math.atan2(e, n)) % 360, 1)}
    return None


def _angle_diff(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


def wind_check(entries: list[dict[str, Any]], sitl_params: dict[str, float]) -> dict[str, Any] | None:
    """The wind set against the one each flight inferred from its own lean and drift (median over the flights):
    ``sign_ok`` when the inferred direction lies within 45 deg of the set one."""
    got = [(e["cond"]["wind_inferred_mps"], e["cond"].get("wind_inferred_from_deg")) for e in entries
           if (e.get("cond") or {}).get("wind_inferred_mps") is not None]
    want = wind_set(sitl_params)
    if not got and want is None:
        return None
    out: dict[str, Any] = {"set": want, "flights": len(got)}
    if got:
        out["inferred_mps"] = round(statistics.median(s for s, _ in got), 2)
        dirs = [d for _, d in got if d is not None]
        if dirs:
            out["inferred_from_deg"] = round(statistics.median(dirs))
            if want is not None:
                out["sign_ok"] = _angle_diff(out["inferred_from_deg"], want["from_deg"]) <= 45.0
    return out


def validation(d: Path) -> dict[str, Any] | None:
    """The validation flights: per comparison its overall word and per manoeuvre the verdict with the judged
    figure's means; every flight that did not complete, with its outcome and message. None without any."""
    from ksbo_mav.campaign.validation_log import ValidationJournal
    from ksbo_mav.campaign.validation_session import validation_verdicts

    path = d / "validation.jsonl"
    if not path.exists():
        return None
    entries = ValidationJournal(path).entries
    pairs = []
    for p in validation_verdicts(d):
        ms = {}
        for m, j in p["manoeuvres"].items():
            ms[m] = {"verdict": j["verdict"], "metric": j["metric"],
                     "baseline": round(statistics.mean(j["baseline"]), 4) if j["baseline"] else None,
                     "candidate": round(statistics.mean(j["candidate"]), 4) if j["candidate"] else None,
                     "spread": None if j["spread"] is None else round(j["spread"], 4),
                     "aborted": [j["baseline_aborted"], j["candidate_aborted"]]}
        pairs.append({"pair": p["pair"], "overall": p["overall"], "manoeuvres": ms})
    flights = {m: sum(e.manoeuvre == m for e in entries) for m in dict.fromkeys(e.manoeuvre for e in entries)}
    other = [{"manoeuvre": e.manoeuvre, "gains": e.gains, "outcome": e.outcome.value, "message": e.message[:200]}
             for e in entries if e.outcome != "ok"]
    return {"flights": flights, "pairs": pairs, "not_completed": other}


def figure8_lean(tlog: str | Path) -> float | None:
    """Largest lean (deg) between the figure-8's start and end markers of one trial's tlog."""
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
            if text.startswith(("ksbo f8h start", "ksbo f8 start")):
                inside = True
            elif text.startswith(("ksbo f8h end", "ksbo f8 end")):
                inside = False
        elif inside and not r.sent and kind == "ATTITUDE":
            lean = math.degrees(tilt_rad(r.msg.roll, r.msg.pitch))
            peak = lean if peak is None else max(peak, lean)
    return peak


def wind_preflight(d: Path, wind_mps: float, stack: str) -> dict[str, Any]:
    """What ``tune --wind`` decided before takeoff (``ksbo_mav.campaign.wind_preflight``, decided again from the
    snapshot as the campaign did), the lean it predicted for the full and the flown figure-8 (worst direction),
    and the peak lean of the baseline's figure-8s (the first flight and its re-flights in the campaign)."""
    from ksbo_mav.campaign.wind_preflight import peak_lean_deg, plan_for_wind, vehicle_drag
    from ksbo_mav.errors import InputError
    from ksbo_mav.mav.params import load_snapshot
    from ksbo_mav.profiles import load_profile
    from ksbo_task.figure8_ne import Figure8H

    settings = json.loads((d / "campaign.json").read_text())
    params = {n: float(v) for n, (v, _type) in load_snapshot(d).params.items()}
    profile = load_profile(settings["profile"])
    m = profile.mission_spec
    f8 = Figure8H(amp_north=m.scale_m, amp_east=m.scale_east_m or m.scale_m, period=m.period_s,
                  altitude=m.center_up_m, lead_in=m.lead_in_s)
    drag = vehicle_drag(params)
    # the limit the campaign flew with (raised by the decision, or set by the user) and the profile's
    tilt = float(((settings.get("config") or {}).get("safety") or {}).get("tilt_max_deg")
                 or profile.safety.tilt_max_deg)
    try:
        plan = plan_for_wind(wind_mps, f8, profile.safety.tilt_max_deg, stack, params)
        decided: dict[str, Any] = {"tilt_max_deg": plan.tilt_max_deg, "scale": plan.scale}
    except InputError as exc:
        decided = {"refused": str(exc)}
    flown_m = settings.get("mission") or {}
    scale = float(flown_m.get("scale", m.scale_m)) / m.scale_m if flown_m else 1.0
    flown = Figure8H(amp_north=f8.amp_north * scale, amp_east=f8.amp_east * scale, period=f8.period,
                     lead_in=f8.lead_in)
    leans, first = [], True
    for p in sorted((d / "trials").glob("trial_*.json")):
        t = json.loads(p.read_text())
        if (first and t.get("label") == "opt") or str(t.get("label", "")).startswith("baseline"):
            first = first and t.get("label") != "opt"
            lean = figure8_lean(t["tlog"]) if t.get("tlog") else None
            if lean is not None:
                leans.append(round(lean, 2))
    return {"drag": drag.source, "decided": decided, "campaign_tilt_max_deg": tilt, "flown_scale": round(scale, 3),
            "predicted_full_deg": round(peak_lean_deg(f8, wind_mps, drag), 2),
            "predicted_flown_deg": round(peak_lean_deg(flown, wind_mps, drag), 2), "baseline_leans_deg": leans}


def tune_wind(tune_args: list[Any]) -> float | None:
    """The ``--wind M/S`` a cell's tune arguments declare, else None."""
    args = [str(a) for a in tune_args or []]
    for i, a in enumerate(args):
        if a == "--wind" and i + 1 < len(args):
            return float(args[i + 1])
        if a.startswith("--wind="):
            return float(a.split("=", 1)[1])
    return None


def record(d: Path, key: dict[str, Any], entries: list[dict[str, Any]]) -> dict[str, Any]:
    """The figures above that apply to this cell, and the cut the campaign said (its first flight's lap-2 RMS
    against its confirmation flights')."""
    out: dict[str, Any] = {}
    opt = [e for e in entries if e.get("kind") == "opt" and e.get("rms")]
    confirm = [round(e["rms"], 4) for e in entries if e.get("kind") == "confirm" and e.get("rms")]
    if opt and confirm:  # the cut the campaign's report says: its first flight against its confirmation flights
        out["said"] = {"baseline_rms": round(opt[0]["rms"], 4), "confirm_rms": confirm,
                       "cut": round(1 - statistics.mean(confirm) / opt[0]["rms"], 4)}
    v = validation(d)
    if v:
        out["validation"] = v
    w = wind_check(entries, key.get("sitl_params") or {})
    if w:
        out["wind"] = w
    declared = tune_wind(key.get("tune_args", []))
    if declared is not None and (d / "campaign.json").exists():
        out["wind_preflight"] = wind_preflight(d, declared, key["vehicle"])
    return out
