"""The day's wind before takeoff, checked against the flights: the lean ``tune --wind`` predicted for the figure-8
(``ksbo_mav.campaign.wind_preflight``, worst wind direction) against the largest lean the campaign's baseline
figure-8s flew (``acos(cos roll cos pitch)`` of the tlog's ATTITUDE between the trial's ``ksbo f8h start`` and
``end`` markers), per stack. One JSON line per campaign to benchmarks/wind-preflight/runs.jsonl; ``report`` writes
results.md.

    python scripts/bench_wind_lean.py record DIR --stack px4 --wind 5 --wind-from 45 --note "..."
    python scripts/bench_wind_lean.py report
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench_common import BENCH, append_record, machine, write_result  # noqa: E402

from ksbo_mav.campaign.wind_preflight import HEADROOM_DEG, peak_lean_deg, plan_for_wind, vehicle_drag  # noqa: E402
from ksbo_mav.errors import InputError  # noqa: E402
from ksbo_mav.mav.params import load_snapshot  # noqa: E402
from ksbo_mav.mav.tlog import read_tlog  # noqa: E402
from ksbo_mav.profiles import load_profile  # noqa: E402
from ksbo_task.figure8_ne import Figure8H  # noqa: E402
from ksbo_task.limit_checks import tilt_rad  # noqa: E402

RUNS = BENCH / "wind-preflight" / "runs.jsonl"


def figure8_lean(tlog: str | Path) -> float | None:
    """Largest lean (deg) between the figure-8's start and end markers of one trial's tlog."""
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


def record(d: Path, stack: str, wind: float, wind_from: float | None, note: str) -> dict:
    settings = json.loads((d / "campaign.json").read_text())
    snap = load_snapshot(d)
    params = {n: float(v) for n, (v, _type) in snap.params.items()}
    profile = load_profile(settings["profile"])
    m = profile.mission_spec
    f8 = Figure8H(amp_north=m.scale_m, amp_east=m.scale_east_m or m.scale_m, period=m.period_s,
                  altitude=m.center_up_m, lead_in=m.lead_in_s)
    flown_m = settings.get("mission") or {}
    drag = vehicle_drag(params)
    try:
        plan = plan_for_wind(wind, f8, profile.safety.tilt_max_deg, stack, params)
        decided = {"tilt_max_deg": plan.tilt_max_deg, "scale": plan.scale, "text": plan.text}
    except InputError as exc:
        decided = {"refused": str(exc)}
    leans, first = [], True
    for p in sorted((d / "trials").glob("trial_*.json")):
        t = json.loads(p.read_text())
        # the baseline: the first optimiser flight (the campaign's reference) and the re-flights of it
        if (first and t.get("label") == "opt") or str(t.get("label", "")).startswith("baseline"):
            first = first and t.get("label") != "opt"
            lean = figure8_lean(t["tlog"]) if t.get("tlog") else None
            if lean is not None:
                leans.append(round(lean, 2))
    scale = float(flown_m.get("scale", m.scale_m)) / m.scale_m if flown_m else 1.0
    flown = Figure8H(amp_north=f8.amp_north * scale, amp_east=f8.amp_east * scale, period=f8.period,
                     lead_in=f8.lead_in)
    return {"stack": stack, "dir": str(d), "wind_mps": wind, "wind_from_deg": wind_from, "note": note,
            "firmware": settings.get("firmware"), "drag": drag.source,
            "predicted_full_deg": round(peak_lean_deg(f8, wind, drag), 2),
            "predicted_flown_deg": round(peak_lean_deg(flown, wind, drag), 2), "flown_scale": round(scale, 3),
            "decided": decided, "headroom_deg": HEADROOM_DEG, "baseline_leans_deg": leans,
            "machine": machine()}


def report() -> None:
    rows = [json.loads(x) for x in RUNS.read_text().splitlines() if x.strip()]
    lines = ["| stack | wind | drag used | predicted peak lean, full / flown figure-8 (deg) | decided before "
             "takeoff | baseline figure-8s flown: peak lean (deg) | note |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        d = r["decided"]
        what = d.get("refused") or (f"tilt limit {d['tilt_max_deg']:g} deg, figure-8 at {d['scale']:.0%}")
        frm = f" from {r['wind_from_deg']:g} deg" if r.get("wind_from_deg") is not None else ""
        flown = ", ".join(f"{x:.1f}" for x in r["baseline_leans_deg"])
        lines.append(f"| {r['stack']} | {r['wind_mps']:g} m/s{frm} | {r['drag']} | {r['predicted_full_deg']:.1f} / "
                     f"{r['predicted_flown_deg']:.1f} | {what} | {flown} | {r['note']} |")
    head = (f"Machine: {rows[-1]['machine']} (newest record). Records: `runs.jsonl` "
            "(`python scripts/bench_wind_lean.py record DIR ...`): the lean `tune --wind` predicts for the figure-8 "
            "in the day's wind (worst direction), what it decided before takeoff, and the peak lean of the "
            "campaign's baseline figure-8s (the first flight and the re-flights).\n\n")
    write_result("wind-preflight", head + "\n".join(lines) + "\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("record")
    r.add_argument("dir", type=Path)
    r.add_argument("--stack", choices=("ardupilot", "px4"), required=True)
    r.add_argument("--wind", type=float, required=True)
    r.add_argument("--wind-from", type=float, default=None)
    r.add_argument("--note", default="")
    sub.add_parser("report")
    a = ap.parse_args()
    if a.cmd == "record":
        rec = record(a.dir, a.stack, a.wind, a.wind_from, a.note)
        append_record(RUNS, rec)
    else:
        report()


if __name__ == "__main__":
    main()
