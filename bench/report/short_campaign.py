"""The short-campaign sweep's page below its header: one row per vehicle, condition and configuration (medians and
worst over the repeats), then each run's re-flown figures. Reads the store's records flat (:func:`flat`)."""

from __future__ import annotations

import statistics
from collections import defaultdict
from typing import Any

#: Labels the results page shows in a section of their own (ksbo_bench.report.early_stop: each seed's newest run).
OWN_SECTION = ("early-stop",)
VEHICLE = {"ardupilot": "ArduCopter SITL", "px4": "PX4 SITL", "copter3d": "JSBSim copter"}


def flat(rec: dict[str, Any]) -> dict[str, Any]:
    """A campaign record as the flat dict of the old runs file: the key's values under their old names (``stack``,
    ``wind_mps``, ``turb``), the result's, ``flights`` the total, ``aborted`` by the gains (aborted and crashed)."""
    k, s, run = rec["key"], rec.get("safety", {}), rec.get("run", {})
    sp = k.get("sitl_params") or {}
    return {**rec.get("result", {}), "label": k.get("label", ""), "stack": k["vehicle"], "seed": k["seed"],
            "tune_args": k.get("tune_args", []), "wind_mps": sp.get("SIM_WIND_SPD", 0.0),
            "turb": sp.get("SIM_WIND_TURB", 0.0), "speedup": k.get("speedup"),
            "flights": rec.get("flights", {}).get("total"), "unsafe": s.get("unsafe") or 0,
            "aborted": (s.get("aborted") or 0) + (s.get("crashed") or 0), "interrupted": s.get("interrupted") or 0,
            "machine": f"{run.get('machine')}, {(run.get('started') or '')[:16].replace('T', ' ')} UTC"}


def condition(r: dict) -> str:
    return f"wind {r['wind_mps']:g} m/s, turbulence {r['turb']:g}" if r.get("wind_mps") else "calm"


def _spread(xs: list[float]) -> str:
    return f"{statistics.mean(xs):.3f} ± {(max(xs) - min(xs)) / 2:.3f}"


def _across(runs: list[dict], key: str) -> str:
    """Median of the runs' re-flown means of ``key`` (m), with their range."""
    means = [statistics.mean(r["reflown"][key]) for r in runs]
    return f"{statistics.median(means):.3f} ({min(means):.3f}–{max(means):.3f})"


def report(records: list[dict[str, Any]]) -> str:
    runs = [flat(r) for r in records]
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
    machine = shown[-1]["machine"] + " (the newest run shown; each run's own in its record)"
    text = "\n".join([
        f"Machine: {machine}. Unsafe: optimiser trials with P < 0; aborted: trials the monitor stopped (the "
        "gains); interrupted: flights stopped by the vehicle, the link or this computer (not the gains). "
        "Flights: every flight of the campaign (baseline = 1, flown prior, optimiser trials, "
        "baseline re-flights, confirmation). Flights to 90 %: median / worst over the runs. Share of L: R's cut "
        "over L's (median). B, R: lap-2 RMS re-flown, the median of the runs' means (their range). Cut: R against "
        "B (median). The paper's rows were measured against the long campaigns of the previous default "
        "(benchmarks/notes/short-campaign.md).",
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
    return text
