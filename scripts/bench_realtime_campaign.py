"""Benchmark records: whole campaigns with their validation flights at the vehicle's real time (SITL speed-up 1)
and with the autopilot's sensor noise and GPS lag raised, on ArduCopter and PX4 SITL.

A campaign is flown with the ordinary tool (``ksbo-mav tune DIR ... --end hold``, its default budget, early stop
and validation), on a SITL started at ``-s 1`` with the settings the record names; this script then reads the
finished campaign directory and appends one record to ``benchmarks/realtime-campaign/runs.jsonl``: flights to
the result, the training figure-8's lap-2 RMS of the baseline and the recommendation, whether the tool kept real
time (how late its setpoints went out and how often LOCAL_POSITION_NED arrived, per trial), the validation
flights' verdict per manoeuvre (the campaign's own rule, ``ksbo_mav.campaign.verdict``) and the interruptions.
``report`` writes ``results.md`` from the records (the results page's section).

    python scripts/bench_realtime_campaign.py record DIR --stack ardupilot --speedup 1 --sensors "..." \
        --command "ksbo-mav tune ..." [--note "..."]
    python scripts/bench_realtime_campaign.py report
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench_common import BENCH, append_record, machine, write_result  # noqa: E402

from ksbo_mav.campaign.validation_log import ValidationJournal  # noqa: E402
from ksbo_mav.campaign.verdict import judge_pairs, worst  # noqa: E402
from ksbo_mav.errors import InputError  # noqa: E402
from ksbo_mav.mav.tlog import read_tlog  # noqa: E402
from ksbo_task.limit_checks import tilt_rad  # noqa: E402

RUNS = BENCH / "realtime-campaign" / "runs.jsonl"


def _trials(d: Path) -> list[dict]:
    return [json.loads(p.read_text()) for p in sorted((d / "trials").glob("trial_*.json"))]


def peak_lean_deg(tlog: str | Path) -> float | None:
    """The largest lean (deg, acos(cos roll cos pitch) of the vehicle's ATTITUDE) of a validation flight's tlog,
    from its start marker to its end marker (or the log's end); None without ATTITUDE there or a readable log."""
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


def _step_leans(entries: list) -> dict[str, list[float | None]]:
    """Peak lean of each step flight of the recommendation's pair, by gain set (baseline, recommendation)."""
    out: dict[str, list[float | None]] = {}
    for e in entries:
        if e.manoeuvre == "steps" and e.pair == "recommendation" and e.tlog:
            out.setdefault(e.gains, []).append(peak_lean_deg(e.tlog))
    return out


def record(d: Path, stack: str, speedup: float, sensors: str, command: str, note: str) -> dict:
    res = json.loads((d / "result.json").read_text())
    trials = _trials(d)
    by_label: dict[str, list[dict]] = {}
    for t in trials:
        by_label.setdefault(t["label"], []).append(t)
    rms = lambda ts: [t["score"]["rms_lap2_m"] for t in ts if t["score"].get("rms_lap2_m") is not None]  # noqa: E731
    lags = [t["link"]["lag_max_ms"] for t in trials if t.get("link", {}).get("lag_max_ms") is not None]
    late = [t["link"]["late_fraction"] for t in trials if t.get("link", {}).get("late_fraction") is not None]
    rates = [t["score"]["rate_hz"] for t in trials if t["score"].get("rate_hz")]
    entries = ValidationJournal(d / "validation.jsonl").entries if (d / "validation.jsonl").exists() else []
    verdicts = {}
    for pv in judge_pairs(entries):
        verdicts[pv.pair] = {m: {"verdict": j.verdict, "metric": j.metric, "base": list(j.base), "cand": list(j.cand),
                                 "spread": j.spread, "diff": j.diff, "base_aborted": j.base_aborted,
                                 "cand_aborted": j.cand_aborted} for m, j in pv.judged.items()}
    val_wall = sum(e.ended_unix - e.started_unix for e in entries if e.ended_unix and e.started_unix)
    cfg = json.loads((d / "campaign.json").read_text()).get("config", {})
    trial_leans = {k: [t["step"].get("peak_lean_deg") for t in ts if t.get("step")] for k, ts in by_label.items()}
    return {"stack": stack, "speedup": speedup, "sensors": sensors, "command": command, "note": note,
            "dir": str(d), "n_trials": res["n_trials"], "flights": len(trials),
            "figure8": "on board" if any(t.get("trajectory", {}).get("on_board") for t in trials) else "streamed",
            "flights_by_label": {k: len(v) for k, v in by_label.items()},
            "outcomes": {o: sum(t["outcome"] == o for t in trials) for o in sorted({t["outcome"] for t in trials})},
            "n_unsafe": res["n_unsafe"], "n_aborted": res["n_aborted"], "n_crashed": res["n_crashed"],
            "n_failed": res["n_failed"], "search_end": _search_end(res.get("search_end")), "wall_s": res.get("wall_s"),
            "baseline_rms": rms([t for t in trials if np.allclose(t["gains"], res["baseline"]["x"])]),
            "confirm_rms": rms(by_label.get("confirm", [])),
            "best_x": res["best"]["x"], "lag_max_ms": max(lags) if lags else None,
            "late_fraction_max": max(late) if late else None, "rate_hz_min": min(rates) if rates else None,
            "validation_flights": len(entries), "validation_wall_s": round(val_wall, 1),
            "validation_outcomes": {o: sum(e.outcome.value == o for e in entries)
                                    for o in {e.outcome.value for e in entries}},
            "verdicts": verdicts, "trial_step": bool(cfg.get("trial_step")),
            "trial_step_leans": {k: v for k, v in trial_leans.items() if v},
            "trial_step_aborts": sum(t["outcome"] == "tilt" and t["message"].startswith("position step")
                                     for t in trials),
            "validation_step_leans": _step_leans(entries)}


def _search_end(s: dict | None) -> str:
    """"early stop after 5 of 10" or "budget 10 flown"."""
    if not s:
        return "–"
    return f"early stop after {s['after']} of {s['budget']}" if s.get("stopped") else f"budget {s['budget']} flown"


def _m(xs: list[float]) -> str:
    return f"{statistics.mean(xs):.3f}" if xs else "–"


def _late(r: dict) -> str:
    if r.get("figure8") == "on board" and r["lag_max_ms"] is None:
        return "none streamed (on board)"
    return f"{r['lag_max_ms'] if r['lag_max_ms'] is not None else '–'}, {(r['late_fraction_max'] or 0):.1%}"


def _change(base: list[float], cand: list[float]) -> str:
    return f" ({statistics.mean(cand) / statistics.mean(base) - 1:+.0%})" if base and cand else ""


def _fig(xs: list[float]) -> str:
    return (f"{statistics.mean(xs):.3g} ({min(xs):.3g}–{max(xs):.3g})" if len(xs) > 1
            else f"{xs[0]:.3g}" if xs else "–")


def _leans(xs: list[float | None] | None) -> str:
    xs = [x for x in xs or [] if x is not None]
    return " / ".join(f"{x:.1f}" for x in xs) if xs else "–"


def transfer_rows(runs: list[dict]) -> list[str]:
    """The training score against the validation's steps, per campaign whose step flights' leans were measured."""
    rows = ["| stack | sensors | training trial | lap-2 RMS baseline → recommendation (training score) | "
            "trials aborted on the step | training step lean (deg): baseline; confirmation | validation step "
            "flights: peak lean (deg) baseline → recommendation | recommendation's step flights aborted | verdict |",
            "|---|---|---|---|---|---|---|---|---|"]
    for r in runs:
        leans = r.get("validation_step_leans")
        if not leans:
            continue
        steps = r["verdicts"].get("recommendation", {}).get("steps", {})
        verdict = "; ".join(f"{m}: {v['verdict']}" for m, v in r["verdicts"].get("recommendation", {}).items())
        trained = r.get("trial_step_leans", {})
        rows.append(f"| {r['stack']} | {r['sensors']} | {'figure-8 + step' if r.get('trial_step') else 'figure-8'} "
                    f"| {_m(r['baseline_rms'])} → {_m(r['confirm_rms'])}{_change(r['baseline_rms'], r['confirm_rms'])} "
                    f"| {r.get('trial_step_aborts', 0) if r.get('trial_step') else '–'} | "
                    f"{_leans(trained.get('opt', [])[:1])}; {_leans(trained.get('confirm'))} | "
                    f"{_leans(leans.get('baseline'))} → {_leans(leans.get('recommendation'))} | "
                    f"{steps.get('cand_aborted', '–')} of {len(leans.get('recommendation', []))} | {verdict} |")
    return rows if len(rows) > 2 else []


def report(write: bool) -> str:
    runs = [json.loads(ln) for ln in RUNS.read_text().splitlines() if ln.strip()] if RUNS.exists() else []
    runs.sort(key=lambda r: (r["stack"], r["sensors"] != "SITL defaults"))  # each stack's defaults first
    rows = ["| stack | speed | sensors | training figure-8 | flights to result (optimiser + confirm) | search end "
            "| lap-2 RMS baseline → "
            "recommendation (m) | setpoints late: max (ms), share | LOCAL_POSITION_NED min (Hz) | interrupted / "
            "aborted / P<0 / crashed | validation flights (wall s) | verdict of the recommendation |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    detail = ["| stack | sensors | manoeuvre | figure | baseline mean (min–max) | recommendation mean (min–max) "
              "| change | verdict |", "|---|---|---|---|---|---|---|---|"]
    for r in runs:
        lab = r["flights_by_label"]
        opt = lab.get("baseline", 0) + lab.get("opt", 0)
        rec = r["verdicts"].get("recommendation", {})
        words = "; ".join(f"{m}: {v['verdict']}" for m, v in rec.items()) or "not flown"
        others = []
        for pair, judged in r["verdicts"].items():
            if pair != "recommendation":
                each = "; ".join(f"{m} {v['verdict']}" for m, v in judged.items())
                others.append(f"{pair}: {worst([v['verdict'] for v in judged.values()])} ({each})")
        words += "".join(f"; next candidate flown, {o}" for o in others)
        interrupted = r["n_failed"]
        rows.append(f"| {r['stack']} | ×{r['speedup']:g} | {r['sensors']} | {r.get('figure8', 'streamed')} | "
                    f"{r['flights']} ({opt} + "
                    f"{lab.get('confirm', 0)}) | {r.get('search_end') or '–'} | {_m(r['baseline_rms'])} → "
                    f"{_m(r['confirm_rms'])}{_change(r['baseline_rms'], r['confirm_rms'])} | "
                    f"{_late(r)} | {r['rate_hz_min'] or '–'} | {interrupted} / "
                    f"{r['n_aborted']} / {r['n_unsafe']} / {r['n_crashed']} | {r['validation_flights']} "
                    f"({r['validation_wall_s']:.0f}) | {words} |")
        for m, v in rec.items():
            change = (f"{statistics.mean(v['cand']) / statistics.mean(v['base']) - 1:+.0%}"
                      if v["base"] and v["cand"] else "–")
            detail.append(f"| {r['stack']} | {r['sensors']} | {m} | {v['metric']} | {_fig(v['base'])} | "
                          f"{_fig(v['cand'])} | {change} | {v['verdict']} |")
    cmds = "\n".join(f"- {r['stack']}, {r['sensors']} ({r['at']}): `{r['command']}`" + (f" — {r['note']}" if
                     r.get("note") else "") for r in runs)
    newest = max(runs, key=lambda r: r["at"])["machine"] if runs else "–"
    machine_line = (f"Machine: {newest} (newest record). Records: `runs.jsonl`, one per "
                    "campaign (`python scripts/bench_realtime_campaign.py record DIR ...`); settings, commands and "
                    "reasons: `benchmarks/notes/realtime-sensors.md`.")
    transfer = transfer_rows(runs)
    body = "\n\n".join([
        machine_line, "\n".join(rows),
        "Each row is one campaign of the tool's defaults (`ksbo-mav tune DIR --end hold`: the profile's budget 10 "
        "with early stop, the simulator prior, one confirmation flight, validation `quick`: each manoeuvre "
        "flown twice per gain set, alternated) on a SITL at real time (`-s 1`). Flights to result = optimiser "
        "trials (baseline included) + confirmation flights; the lap-2 RMS is the training figure-8's (3-D, m). "
        "Setpoints late: how far past its due time on the vehicle's clock the worst setpoint of any trial went out, "
        "and the largest share of a trial's setpoints sent late; the verdict is the campaign's own (better / no "
        "measurable change / worse beyond the repeats' spread).",
        *(["The training score against the validation's position steps (what the optimiser saw against what a "
           "pilot's position change asks): the training trial with the figure-8 alone, or with the position step "
           "after it (`tune --trial-step`); lean = acos(cos roll · cos pitch) of the tlog's ATTITUDE, the training "
           "step's from the trial records (the baseline's first trial; the confirmation), the validation's from "
           "each step flight's tlog, from its start marker to its end marker (an aborted flight's goes out when "
           "the monitor stops it):", "\n".join(transfer)] if transfer else []),
        "Validation figures of the recommendation against the baseline (deciding figure: steps mean settling "
        "time s, or the mean overshoot % where a step did not settle within its dwell; hold RMS drift m; AUTO "
        "mission cross-track RMS m; lower is better):",
        "\n".join(detail), "Commands:\n\n" + cmds])
    print(body)
    if write:
        write_result("realtime-campaign", body)
    return body


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("record", help="append the record of a finished campaign directory")
    r.add_argument("dir", type=Path)
    r.add_argument("--stack", choices=["ardupilot", "px4"], required=True)
    r.add_argument("--speedup", type=float, default=1.0)
    r.add_argument("--sensors", required=True, help="the SITL's sensor settings in a few words")
    r.add_argument("--command", required=True, help="the tune command as run")
    r.add_argument("--note", default="")
    sub.add_parser("report", help="write results.md from the records")
    a = ap.parse_args()
    if a.cmd == "record":
        rec = record(a.dir, a.stack, a.speedup, a.sensors, a.command, a.note)
        if RUNS.exists():  # a campaign recorded again replaces its earlier record
            keep = [ln for ln in RUNS.read_text().splitlines() if ln.strip() and json.loads(ln)["dir"] != rec["dir"]]
            RUNS.write_text("".join(ln + "\n" for ln in keep))
        append_record(RUNS, {**rec, "machine": machine(), "at": time.strftime("%Y-%m-%d %H:%M", time.gmtime())})
    report(True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
