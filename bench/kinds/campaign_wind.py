"""The campaign cell's ``wind`` analysis (ksbo_bench.kinds.campaign_analyses): the wind the flights inferred
beside the wind the cell set (its sign checked before a number is written), and with ``tune --wind`` what was
decided before takeoff against the lean the baseline's figure-8s flew.

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

#: A trial's figure-8 in its tlog: the tuner's start and end markers (on-board and streamed figure-8s).
F8_START, F8_END = ("ksbo f8h start", "ksbo f8 start"), ("ksbo f8h end", "ksbo f8 end")

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


def wind_preflight(d: Path, wind_mps: float, stack: str) -> dict[str, Any]:
    """What ``tune --wind`` decided before takeoff (``ksbo_mav.campaign.wind_preflight``, decided again from the
    snapshot as the campaign did), the lean it predicted for the full and the flown figure-8 (worst direction),
    and the peak lean of the baseline's figure-8s (the first flight and its re-flights in the campaign)."""
    from ksbo_bench.kinds.campaign_validation import peak_lean_deg
    from ksbo_mav.campaign.wind_preflight import peak_lean_deg as predicted_lean_deg, plan_for_wind, vehicle_drag
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
            lean = peak_lean_deg(t["tlog"], F8_START, F8_END) if t.get("tlog") else None
            if lean is not None:
                leans.append(round(lean, 2))
    return {"drag": drag.source, "decided": decided, "campaign_tilt_max_deg": tilt, "flown_scale": round(scale, 3),
            "predicted_full_deg": round(predicted_lean_deg(f8, wind_mps, drag), 2),
            "predicted_flown_deg": round(predicted_lean_deg(flown, wind_mps, drag), 2), "baseline_leans_deg": leans}


def tune_wind(tune_args: list[Any]) -> float | None:
    """The ``--wind M/S`` a cell's tune arguments declare, else None."""
    args = [str(a) for a in tune_args or []]
    for i, a in enumerate(args):
        if a == "--wind" and i + 1 < len(args):
            return float(args[i + 1])
        if a.startswith("--wind="):
            return float(a.split("=", 1)[1])
    return None


def analysis(key: dict[str, Any], d: Path, result: dict[str, Any]) -> None:
    """The figures above that apply to the cell, added to ``result``: ``wind`` (with any wind set or inferred) and
    ``wind_preflight`` (with ``--wind`` among the tune arguments)."""
    entries = [json.loads(x) for x in (d / "journal.jsonl").read_text().splitlines() if x.strip()]
    w = wind_check(entries, key.get("sitl_params") or {})
    if w:
        result["wind"] = w
    declared = tune_wind(key.get("tune_args", []))
    if declared is not None and (d / "campaign.json").exists():
        result["wind_preflight"] = wind_preflight(d, declared, key["vehicle"])
