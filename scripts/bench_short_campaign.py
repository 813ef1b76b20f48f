"""Flights to 90 %: how many flights a copter campaign needs before its best gains, re-flown by separate flights,
give 90 % of the lap-RMS cut that a long (~40-flight) campaign's recommendation gives.

One run: a fresh vehicle (ArduCopter SITL at -s 10, calm or in wind; PX4 SITL at -s 5; our JSBSim copter in
lockstep), ``ksbo-mav tune`` with the given options, then, on the vehicle it left hovering, the baseline (B), the
long campaign's recommendation (L, ``--reference DIR``), this campaign's recommendation (R) and its best-so-far
gains at the last few flights where they changed (the flight's own lap RMS, no model value) flown in turn three
times each (the same condition). 90 % is reached at flight k when the best-so-far gains after flight k re-fly
(mean) at or below ``B - 0.9 (B - L)``; flights count the baseline as 1 and every flight the campaign made
(prior, re-flights of the baseline, confirmation). One JSON line per run, appended to
benchmarks/short-campaign/runs.jsonl; ``--report`` folds them into the short-campaign sweep's store
(benchmarks/store/short-campaign, where ``ksbo-bench run short-campaign`` writes its cells) and rebuilds the pages
(benchmarks/pages/short-campaign.md, BENCHMARKS.md). A sweep cell does what one run here does.

    python scripts/bench_short_campaign.py --stack ardupilot --reference DIR --seed 0 [--wind 5 --turb 1] -- TUNE-ARGS
    python scripts/bench_short_campaign.py --stack px4 --seed 0 -- --budget 30        # a long (reference) campaign
    python scripts/bench_short_campaign.py --report
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

from _bench_common import append_record, machine, refly_in_turn  # noqa: E402

from ksbo_bench.kinds.campaign import best_so_far  # noqa: E402 - the campaign cell kind's, one copy

OUT = ROOT / "benchmarks" / "short-campaign" / "runs.jsonl"
SPEED = {"ardupilot": 10.0, "px4": 5.0}
N_CANDIDATES = 4


@contextmanager
def vehicle(a: argparse.Namespace):
    """(tune's connection arguments, Endpoint) of a fresh vehicle."""
    if a.stack in SPEED:
        from _bench_common import endpoint

        from ksbo_sim.sitl import start_sitl

        sitl = start_sitl(a.stack, instance=a.instance, speedup=a.speedup or SPEED[a.stack])
        try:
            if a.stack == "px4":
                sitl.set_param("COM_RCL_EXCEPT", 4, int32=True)  # no RC in SITL: allow OFFBOARD without it
            if a.wind:
                sitl.set_param("SIM_WIND_SPD", a.wind)
                sitl.set_param("SIM_WIND_TURB", a.turb)
            yield endpoint(sitl)
        finally:
            sitl.stop()
    else:
        from _bench_common import sim_and_endpoint

        sets = [arg for kv in a.sim_set for arg in ("--set", kv)]
        with sim_and_endpoint("--vehicle", "copter3d", "--personality", "ardupilot", *sets) as (_sim, ep):
            yield ["--udp", f"127.0.0.1:{ep.port}"], ep


def recorded_gains(a: argparse.Namespace) -> dict[str, float]:
    """The recommendation of the run labelled ``a.reference_label`` on this vehicle and condition, from
    runs.jsonl (the long campaigns' directories are temporary; their gains are on record)."""
    for line in reversed(OUT.read_text().splitlines()):
        r = json.loads(line)
        if (r.get("label") == a.reference_label and r["stack"] == a.stack and r["wind_mps"] == a.wind
                and r["turb"] == a.turb and r.get("best_values")):
            return r["best_values"]
    raise SystemExit(f"no run labelled {a.reference_label!r} for {a.stack} wind {a.wind} in {OUT}")


def run(a: argparse.Namespace) -> dict:
    d = Path(tempfile.mkdtemp(prefix="bench-short-")) / "campaign"
    rec: dict = {"stack": a.stack, "wind_mps": a.wind, "turb": a.turb, "seed": a.seed, "tune_args": a.tune,
                 "reference": a.reference or (f"label {a.reference_label}" if a.reference_label else None)}
    with vehicle(a) as (args, ep):
        t0 = time.time()
        r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), *args, "--seed", str(a.seed),
                            "--end", "hold", "--json", *a.tune], capture_output=True, text=True, timeout=7200)
        rec.update(rc=r.returncode, wall_s=round(time.time() - t0, 1), dir=str(d))
        if r.returncode != 0:
            rec["error"] = (r.stderr.strip().splitlines() or ["?"])[-1][:300]
            return rec
        entries = [json.loads(x) for x in (d / "journal.jsonl").read_text().splitlines() if x.strip()]
        best = json.loads((d / "result.json").read_text())["best"]
        names = list(best["values"])
        rec["flights"] = len(entries)
        rec["kinds"] = {k: sum(e["kind"] == k for e in entries) for k in sorted({e["kind"] for e in entries})}
        rec["rms_per_flight"] = [round(e["rms"], 4) if e.get("rms") else None for e in entries]
        rec["unsafe"] = sum(e["kind"] == "opt" and e["P"] < 0 for e in entries)
        rec["aborted"] = sum(e["outcome"] in ("fence", "tilt", "track", "crash") for e in entries)  # by the gains
        rec["interrupted"] = sum(e["kind"] == "failed" for e in entries)  # the vehicle, link or computer
        cands = best_so_far(entries, names)[-a.candidates:] if a.candidates else []
        rec["candidates"] = [(k, round(rms, 4)) for k, _, rms in cands]
        gains = {"rec": best["values"], **{f"f{k}": g for k, g, _ in cands}}
        for k in a.refly_after:  # the best flown gains after flight k, whether or not among the last changes
            upto = [g for j, g, _ in best_so_far(entries, names) if j <= k]
            if upto:
                gains[f"after{k}"] = upto[-1]
        if a.reference:
            gains["long"] = json.loads((Path(a.reference) / "result.json").read_text())["best"]["values"]
        elif a.reference_label:
            gains["long"] = recorded_gains(a)
        rec["search_end"] = json.loads((d / "result.json").read_text()).get("search_end")
        try:
            rec["reflown"] = refly_in_turn(d, ep, gains)
        except Exception as exc:  # noqa: BLE001 - the campaign's own figures are kept; the re-flights are said lost
            rec["error"] = f"re-flights: {type(exc).__name__}: {str(exc)[:300]}"
            rec["speedup"] = a.speedup
            return rec
        rec["candidates_reflown"] = a.candidates
        rec["best_values"] = best["values"]
    rec["speedup"] = a.speedup or SPEED.get(a.stack)
    m = {k: statistics.mean(v) for k, v in rec["reflown"].items()}
    rec["cut"] = 1 - m["rec"] / m["baseline"]
    if "long" in m:
        target = m["baseline"] - 0.9 * (m["baseline"] - m["long"])
        rec["target_rms"] = target
        hits = [k for k, _, _ in cands if m[f"f{k}"] <= target]
        rec["flights_to_90"] = min(hits) if hits else (rec["flights"] if m["rec"] <= target else None)
        rec["share_of_long"] = (m["baseline"] - m["rec"]) / (m["baseline"] - m["long"])
    rec["machine"] = machine()
    return rec


def main() -> None:
    if "--report" in sys.argv:  # the runs are a sweep's records now: folded into its store, then the pages
        from ksbo_bench.convert_legacy import fold_short_campaign
        from ksbo_bench.report.pages import main as pages

        fold_short_campaign(OUT)
        sys.exit(pages())
    argv = sys.argv[1:]
    tune = argv[argv.index("--") + 1:] if "--" in argv else []
    argv = argv[:argv.index("--")] if "--" in argv else argv
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stack", choices=("ardupilot", "px4", "copter3d"), default="ardupilot")
    ap.add_argument("--reference", help="the long campaign whose recommendation is 100 %%")
    ap.add_argument("--reference-label", help="the long campaign by its label in runs.jsonl (its recorded gains)")
    ap.add_argument("--candidates", type=int, default=N_CANDIDATES,
                    help="best-so-far gains re-flown besides B, L, R (0: none; flights to 90 %% then from R)")
    ap.add_argument("--label", default="", help="a name for the configuration (the report groups by it)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--wind", type=float, default=0.0, help="SITL: SIM_WIND_SPD (m/s)")
    ap.add_argument("--turb", type=float, default=0.0, help="SITL: SIM_WIND_TURB")
    ap.add_argument("--instance", type=int, default=3, help="SITL instance (PX4: 0..9)")
    ap.add_argument("--speedup", type=float, default=0.0,
                    help="SITL speed-up (0: ArduCopter 10, PX4 5); lower on a loaded machine")
    ap.add_argument("--sim-set", action="append", default=[], metavar="NAME=VALUE",
                    help="our JSBSim copter: a parameter set at start (ksbo-mav sim --set), e.g. MOT_THST_HOVER=0.5")
    ap.add_argument("--refly-after", type=lambda t: [int(k) for k in t.split(",")], default=[], metavar="K,K",
                    help="also re-fly the best flown gains after these flights (e.g. 2,3)")
    a = ap.parse_args(argv)
    a.tune = tune
    r = run(a)
    r["label"] = a.label
    append_record(OUT, r)


if __name__ == "__main__":
    main()
