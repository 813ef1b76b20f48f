"""benchmarks/short-campaign/results.md from the runs of ``scripts/bench_short_campaign.py`` (one row per
vehicle, condition and configuration; medians and worst over the repeats)."""

from __future__ import annotations

import json
import statistics
from collections import defaultdict
from pathlib import Path

VEHICLE = {"ardupilot": "ArduCopter SITL", "px4": "PX4 SITL", "copter3d": "JSBSim copter"}


def condition(r: dict) -> str:
    return f"wind {r['wind_mps']:g} m/s, turbulence {r['turb']:g}" if r.get("wind_mps") else "calm"


def _spread(xs: list[float]) -> str:
    return f"{statistics.mean(xs):.3f} ± {(max(xs) - min(xs)) / 2:.3f}"


def report(runs_path: Path) -> None:
    runs = [json.loads(x) for x in runs_path.read_text().splitlines() if x.strip()]
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for r in runs:
        if r.get("label", "").startswith("try-"):
            continue  # a design tried on the way (benchmarks/notes), not a configuration on the results page
        groups[(VEHICLE[r["stack"]], condition(r), r["label"], " ".join(r["tune_args"]))].append(r)
    rows, figures = [], []
    for (veh, cond, label, args), rs in groups.items():
        ok = [r for r in rs if "reflown" in r]
        failed = len(rs) - len(ok)
        if "long" in (ok[0]["reflown"] if ok else {}):
            hit = [r["flights_to_90"] for r in ok]
            reached = sorted(h for h in hit if h is not None)
            med = statistics.median(h if h is not None else 99 for h in hit) if hit else None
            to90 = (f"{'–' if med is None or med == 99 else f'{med:g}'} / "
                    f"{max(reached) if len(reached) == len(hit) and hit else 'not reached'}")
            share = f"{statistics.median(r['share_of_long'] for r in ok):.0%}" if ok else "–"
            rows.append(f"| {veh} | {cond} | {label} (`{args}`) | {len(ok)}{f' (+{failed} failed)' if failed else ''}"
                        f" | {statistics.median(r['flights'] for r in ok):g} | {to90} | {share} | "
                        f"{statistics.median(r['cut'] for r in ok):.1%} | "
                        f"{sum(r['unsafe'] for r in ok)} / {sum(r['aborted'] for r in ok)} |")
        for r in ok:
            b, rec = r["reflown"]["baseline"], r["reflown"]["rec"]
            figures.append(f"| {veh} | {cond} | {label} | {r['seed']} | {r['flights']} | {_spread(b)} | "
                           f"{_spread(rec)} | {r['cut']:.1%} |")
    machine = runs[-1]["machine"]
    text = "\n".join([
        "# Flights to 90 %: a campaign that fits in one battery",
        "",
        "Command: `python scripts/bench_short_campaign.py --stack STACK [--wind 5 --turb 1] --reference LONG --seed "
        "S --label NAME -- TUNE-ARGS`, then `--report`. Each run: a fresh vehicle (ArduCopter SITL -s 10, PX4 SITL "
        "-s 5, our JSBSim copter in lockstep), `ksbo-mav tune` with the configuration's arguments and seed S; then, "
        "on the vehicle the campaign left hovering, the baseline (B), the long campaign's recommendation (L: a "
        "~40-flight default campaign on the same vehicle and condition), this campaign's recommendation (R) and "
        "the best flown gains at the last four flights where they changed, flown in turn 3 times each (same "
        "condition, same speed-up).",
        "",
        f"Machine: {machine}. Flights: every flight of the campaign (baseline = 1, flown prior, optimiser trials, "
        "baseline re-flights, confirmation). Flights to 90 %: the first flight after which the best flown gains, "
        "re-flown, give at least 90 % of L's cut (re-flown mean <= B - 0.9 (B - L)); median / worst over the "
        "runs. Share of L: R's cut over L's (median). Cut: R against B, re-flown (median).",
        "",
        "| vehicle | condition | configuration | runs | flights | flights to 90 % (median / worst) | R's share "
        "of L's cut | cut | unsafe / aborted |",
        "|---|---|---|---|---|---|---|---|---|",
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
