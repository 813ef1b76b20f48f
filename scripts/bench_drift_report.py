"""Write benchmarks/drift/results.md from the drift benchmarks' records (copter-runs.jsonl, sitl-runs.jsonl,
planar-static-runs.jsonl, written by scripts/bench_drift_copter.py, bench_drift_sitl.py, bench_drift_planar.py).
The planar runs of the first drift work (their own table, kept by hand in planar-changes.md) follow as they are.

    python scripts/bench_drift_report.py
"""

from __future__ import annotations

import json
import statistics
from pathlib import Path

OUT = Path(__file__).resolve().parents[1] / "benchmarks" / "drift"


def _load(name: str) -> list[dict]:
    p = OUT / name
    return [json.loads(x) for x in p.read_text().splitlines() if x.strip()] if p.exists() else []


def _reflown(r: dict) -> str:
    if not r.get("reflown_baseline"):
        return "–"
    b, x = statistics.mean(r["reflown_baseline"]), statistics.mean(r["reflown_best"])
    return f"{b:.3f} → {x:.3f} m (−{100 * (1 - x / b):.1f} %)"


def _test(r: dict, at: str) -> str:
    if not r.get("drift"):
        return "did not fire"
    trial = r["drift"].split("(trial ")[1].split(",")[0]
    return f"fired at trial {trial}{at}"


def copter_rows(runs: list[dict]) -> list[str]:
    static = next((r for r in runs if r["run"] == "static"), None)
    rows = []
    for r in runs:
        b = r["baseline_rms"]
        what = {"static": "static", "stop": f"drag +{r['rise_per_min']:g}/min of flight, `--on-drift stop`",
                "continue": f"drag +{r['rise_per_min']:g}/min of flight, `--on-drift continue`"}[r["run"]]
        at = ""
        if r.get("detectable_trial") is not None:
            at = f" (detectable at trial {r['detectable_trial']}"
            at += f"; stopped at {r['stopped_trial']}, {r['stopped_trial'] - r['detectable_trial']} later)" \
                if r.get("stopped_trial") is not None else ")"
        share = ""
        if r["run"] == "continue" and static and r.get("cut") and static.get("cut"):
            share = f"; {100 * r['cut'] / static['cut']:.0f} % of the static campaign's cut"
        rows.append(f"| JSBSim copter | {what} | {r['flights']} | {r['baseline_reflights']} "
                    f"({100 * r['baseline_reflights'] / r['budget']:.0f} %) | {b[0]:.3f} → {b[-1]:.3f} | "
                    f"{_test(r, at)} | {r['unsafe_told']} ({r['unsafe_for_drift']}) | {_reflown(r)}{share} |")
    return rows


def sitl_rows(runs: list[dict]) -> list[str]:
    rows = []
    for r in runs:
        b = [x[1] for x in r["baseline_rms"]]
        if r["wind_mps"]:
            what = f"wind 0 → {r['wind_mps']:g} m/s at trial {r['wind_at']}, `--on-drift {r['on_drift']}`"
        else:
            what = "calm" + (f", `--baseline-every {r['baseline_every']}`" if r.get("baseline_every") is not None
                             else "")
        n = r["kinds"].get("baseline", 0)
        rows.append(f"| ArduCopter SITL | {what} | {r['flights']} | {n} ({100 * n / r['budget']:.0f} %) | "
                    f"{b[0]:.3f} → {b[-1]:.3f} | {_test(r, '')} | {r['unsafe_told']} (–) | {_reflown(r)} |")
    return rows


def planar_rows(runs: list[dict]) -> list[str]:
    by: dict[str, dict[str, dict]] = {}
    for r in runs:
        seed, every = r["run"].split("-")[1], r["run"].split("every")[1]
        by.setdefault(seed, {})[every] = r
    rows = []
    for seed, d in sorted(by.items()):
        a, b = d.get("7"), d.get("0")
        if a and b:
            rows.append(f"| {seed[1:]} | {a['baseline_reflights']} | {a['reflown_P']:.3f} | {b['reflown_P']:.3f} | "
                        f"{a['unsafe_opt']} / {b['unsafe_opt']} |")
    return rows


def main() -> None:
    copter, sitl, planar = _load("copter-runs.jsonl"), _load("sitl-runs.jsonl"), _load("planar-static-runs.jsonl")
    machine = (copter or sitl or planar)[-1].get("machine", "")
    lines = [
        "# A vehicle that changes: baseline re-flights, the drift test, the correction",
        "",
        "Commands: `python scripts/bench_drift_copter.py` (our JSBSim copter, ArduPilot names, in its own process, "
        "lockstep; drag rising 0.03 per minute of flight, about doubling the baseline's lap-2 RMS over a budget of "
        "30), `python scripts/bench_drift_sitl.py` (ArduCopter SITL at -s 10; the wind set through its second port "
        "once 15 trials are journalled; `--wind 0`: calm), `python scripts/bench_drift_planar.py static-sS-everyN "
        "30 --tune --seed S --baseline-every N`; table by `python scripts/bench_drift_report.py`.",
        "",
        f"Machine: {machine}. One campaign per row, `--budget 30`, default prior (8 flown prior trials on the "
        "copters). Re-flown: the baseline and the recommendation flown alternately three times each (B R B R B R) on "
        "the vehicle the campaign left hovering, i.e. in the final condition. \"Detectable\": the first trial at "
        "which the baseline's true lap-2 RMS (flown in process at that trial's drag) is 25 % over its start, the "
        "test's floor. Unsafe: optimiser trials given P < 0 (corrected P where there is one); in brackets, those "
        "whose gains beat the baseline flown in process in the same condition (unsafe for drift alone).",
        "",
        "| vehicle | condition | flights | baseline re-flights (share of budget) | baseline lap-2 RMS (m): start → "
        "last | drift test | unsafe (for drift) | re-flown in the final condition: baseline → recommendation |",
        "|---|---|---|---|---|---|---|---|",
        *copter_rows(copter), *sitl_rows(sitl),
        "",
        "ArduCopter SITL reports its wind estimate as 0 (its EKF estimates wind on a multicopter only with drag "
        "fusion, `EK3_DRAG_BCOEF_*`, off by default): the wind column of the journal is 0.0 there, and the message "
        "names no wind. SIM_WIND_SPD, set by the benchmark, is the one parameter left changed.",
        "",
        "### The planar task, static: with and without the re-flights",
        "",
        "| tune seed | re-flights (`--baseline-every 7`) | re-flown P, default | re-flown P, `--baseline-every 0` | "
        "P < 0 trials (default / none) |",
        "|---|---|---|---|---|",
        *planar_rows(planar),
        "",
        "Re-flown P: the recommendation from the 8 fixed starts in process (`ksbo-mav evaluate --fixed`).",
        "",
    ]
    hand = OUT / "planar-changes.md"
    text = "\n".join(lines) + ("\n" + hand.read_text() if hand.exists() else "")
    (OUT / "results.md").write_text(text)
    print(f"wrote {OUT / 'results.md'}")


if __name__ == "__main__":
    main()
