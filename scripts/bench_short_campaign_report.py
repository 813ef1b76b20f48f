"""benchmarks/short-campaign/results.md from the runs of ``scripts/bench_short_campaign.py`` (one row per
vehicle, condition and configuration; medians and worst over the repeats)."""

from __future__ import annotations

import json
import statistics
from collections import defaultdict
from pathlib import Path

#: Labels the results page shows in a section of their own (ksbo_bench.report.early_stop: each seed's newest run).
OWN_SECTION = ("early-stop",)
VEHICLE = {"ardupilot": "ArduCopter SITL", "px4": "PX4 SITL", "copter3d": "JSBSim copter"}


def condition(r: dict) -> str:
    return f"wind {r['wind_mps']:g} m/s, turbulence {r['turb']:g}" if r.get("wind_mps") else "calm"


def _spread(xs: list[float]) -> str:
    return f"{statistics.mean(xs):.3f} ± {(max(xs) - min(xs)) / 2:.3f}"


def _across(runs: list[dict], key: str) -> str:
    """Median of the runs' re-flown means of ``key`` (m), with their range."""
    means = [statistics.mean(r["reflown"][key]) for r in runs]
    return f"{statistics.median(means):.3f} ({min(means):.3f}–{max(means):.3f})"


def report(runs_path: Path) -> None:
    runs = [json.loads(x) for x in runs_path.read_text().splitlines() if x.strip()]
    groups: dict[tuple, list[dict]] = defaultdict(list)
    shown: list[dict] = []
    for r in runs:
        if r.get("label", "").startswith(("try-", "was-")):
            continue  # a design tried on the way, or an earlier default (benchmarks/notes), not on the results page
        if r.get("label") in OWN_SECTION:
            continue
        groups[(VEHICLE[r["stack"]], condition(r), r["label"], " ".join(r["tune_args"]))].append(r)
        shown.append(r)
    rows, figures = [], []
    def order(kv: tuple) -> tuple:
        veh, cond, label, _ = kv[0]
        return veh, cond, label != "default", label

    for (veh, cond, label, args), rs in sorted(groups.items(), key=order):
        ok = [r for r in rs if "reflown" in r]
        failed = len(rs) - len(ok)
        if "long" in (ok[0]["reflown"] if ok else {}):
            hit = [r["flights_to_90"] for r in ok]
            reached = sorted(h for h in hit if h is not None)
            med = statistics.median(h if h is not None else 99 for h in hit) if hit else None
            to90 = (f"{'not reached' if med is None or med == 99 else f'{med:g}'} / "
                    f"{max(reached) if len(reached) == len(hit) and hit else 'not reached'}")
            share = f"{statistics.median(r['share_of_long'] for r in ok):.0%}" if ok else "–"
            rows.append(f"| {veh} | {cond} | {label} (`{args}`) | {len(ok)}{f' (+{failed} failed)' if failed else ''}"
                        f" | {statistics.median(r['flights'] for r in ok):g} | {to90} | {share} | "
                        f"{_across(ok, 'baseline')} | {_across(ok, 'rec')} | "
                        f"{statistics.median(r['cut'] for r in ok):.1%} | "
                        f"{sum(r['unsafe'] for r in ok)} / {sum(r['aborted'] for r in ok)} / "
                        f"{sum(r.get('interrupted', 0) for r in ok)} |")
        for r in sorted(ok, key=lambda r: r["seed"]):
            b, rec = r["reflown"]["baseline"], r["reflown"]["rec"]
            figures.append(f"| {veh} | {cond} | {label} | {r['seed']} | {r['flights']} | {_spread(b)} | "
                           f"{_spread(rec)} | {r['cut']:.1%} |")
    machine = shown[-1]["machine"] + " (the newest run shown; each run's own in runs.jsonl)"
    text = "\n".join([
        "# Flights to 90 %: a campaign that fits in one battery",
        "",
        "Command: `python scripts/bench_short_campaign.py --stack STACK [--wind 5 --turb 1] --reference LONG --seed "
        "S --label NAME -- TUNE-ARGS`, then `--report`. Each run: a fresh vehicle (ArduCopter SITL -s 10, PX4 SITL "
        "-s 5, our JSBSim copter in lockstep), `ksbo-mav tune` with the configuration's arguments and seed S; then, "
        "on the vehicle the campaign left hovering, the baseline (B), the long campaign's recommendation (L), "
        "this campaign's recommendation (R) and the best flown gains at the last four flights where they changed, "
        "flown in turn 3 times each (same condition, same speed-up). L: a ~40-flight campaign on the same vehicle "
        "and condition, today's default with `--budget 35` (39 flights, rows \"long\" below). The paper's rows "
        "were measured against the long campaigns of the previous default (benchmarks/notes/short-campaign.md).",
        "",
        f"Machine: {machine}. Unsafe: optimiser trials with P < 0; aborted: trials the monitor stopped (the "
        "gains); interrupted: flights stopped by the vehicle, the link or this computer (not the gains). "
        "Flights: every flight of the campaign (baseline = 1, flown prior, optimiser trials, "
        "baseline re-flights, confirmation). Flights to 90 %: the first flight after which the best flown gains, "
        "re-flown, give at least 90 % of L's cut (re-flown mean <= B - 0.9 (B - L)); median / worst over the "
        "runs. Share of L: R's cut over L's (median). B, R: lap-2 RMS re-flown, the median of the runs' means (their "
        "range). Cut: R against B (median).",
        "",
        "| vehicle | condition | configuration | runs | flights | flights to 90 % (median / worst) | R's share "
        "of L's cut | B (m) | R (m) | cut | unsafe / aborted / interrupted |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
        *rows,
        "",
        "## Each run: baseline and recommendation re-flown (lap-2 RMS, m, mean ± half range of 3 flights)",
        "",
        "| vehicle | condition | configuration | seed | flights | B | R | cut |",
        "|---|---|---|---|---|---|---|---|",
        *figures,
        "",
    ])
    (runs_path.parent / "results.md").write_text(text)
    print(f"wrote {runs_path.parent / 'results.md'}")
