"""Benchmark: full tuning campaigns (simulator prior + N trials) against `ksbo-mav sim --lockstep` over UDP.

Reports wall time, the recommendation's P re-flown over MAVLink and its in-process re-flown E[P] over the fixed
initial conditions (comparable with the in-process optimiser benchmark), unsafe and aborted trials, and whether
every exit left the baseline verified on the vehicle. With ``--write`` (or ``--report``) it writes
benchmarks/mavlink-campaign/results.md (``ksbo-bench report`` takes BENCHMARKS.md's headline from it); a
plain run only prints it (and keeps OUT/results.json), so a one-off experiment does not replace the committed one.

    python scripts/bench_tune_campaign.py [--seeds 0 1 2] [--budget 60] [--methods ksbo ksbo-adaptive]
        [--out bench-runs/tune] [--write]          # bench-runs/ is ignored by git: keep a result in benchmarks/
    python scripts/bench_tune_campaign.py --report A/results.json B/results.json   # combine runs split over processes
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _bench_common import machine, write_result  # noqa: E402


def run_one(seed: int, budget: int, out: Path, method: str, options: dict | None = None) -> dict:
    from ksbo_mav.mav.link import Endpoint
    from ksbo_mav.simulated.planar_objective import SimObjective
    from ksbo_mav.profiles import load_profile
    from ksbo_mav.campaign import Campaign, CampaignConfig
    from ksbo_sim.process import free_udp_port
    from ksbo_sim.testing import SimProcess, read_params

    d = out / f"{method}-seed{seed}"
    shutil.rmtree(d, ignore_errors=True)
    prof = load_profile("sim-planar")
    baseline = {n: float(np.float32(x)) for n, x in zip(prof.names, prof.default)}
    port = free_udp_port()
    with SimProcess("--lockstep", out_port=port) as sim:
        t = time.monotonic()
        s = Campaign(CampaignConfig(dir=str(d), budget=budget, seed=seed, prior="sim", end="hold",
                                    method=method, options=dict(options or {})),
                     Endpoint("udp", "127.0.0.1", port), log=lambda m: None).run()
        wall = time.monotonic() - t
        restored_end = read_params(sim, prof.names) == baseline  # independent plain-pymavlink read
    records = [json.loads(line) for line in (d / "journal.jsonl").read_text().splitlines()]
    sim_obj = SimObjective("sim-planar", monitor=True)  # re-flights judged as the plant suite judges them
    e_best = float(sim_obj.expected(np.array(s["best"]["x"]))[0])
    e_base = float(sim_obj.expected(np.array(s["baseline"]["x"]))[0])
    # The same optimiser, prior, bounds and seed in process (noisy random-initial-velocity episodes): the
    # reference the MAVLink campaign should match.
    from threadpoolctl import threadpool_limits

    from ksbo_mav import optimize
    from ksbo_mav.campaign import optimizer_options

    camp = json.loads((d / "campaign.json").read_text())
    prior = json.loads((d / "prior.json").read_text())
    with threadpool_limits(1):
        ref = optimize(SimObjective("sim-planar", seed=seed, monitor=True), np.array(camp["x0"]),
                       np.array(camp["bounds"]), budget=budget, seed=seed,
                       prior=(np.array(prior["X"]), np.array(prior["y"])), method=method,
                       **optimizer_options(prior["kind"], camp["config"].get("options", {}), method, prof))
    e_ref = float(sim_obj.expected(ref.x)[0])
    label = method + "".join(f" {k}={v}" for k, v in (options or {}).items())
    return {"method": label, "seed": seed, "wall_s": wall, "trials": len(records), "P_base": s["baseline"]["P"],
            "P_confirm": s["best"]["P_confirm"], "E_best": e_best, "E_base": e_base, "unsafe": s["n_unsafe"],
            "aborted": s["n_aborted"], "crashed": s["n_crashed"],
            "unrestored": sum(not r["restored"] for r in records) + (not restored_end),
            "orders": s["orders"], "wall_per_trial": wall / len(records), "E_inproc": e_ref,
            "unsafe_inproc": int(ref.n_unsafe), "aborted_inproc": int(ref.n_aborted),
            "crashed_inproc": int(ref.n_crashed)}


def report(rows: list[dict], command: str) -> str:
    """The results page for ``rows`` (one per campaign, any methods): a summary per method, then every campaign."""
    table = ["| method | seed | trials | wall (s) | s/trial | baseline P | re-flown P (MAVLink) | E[P] best / baseline "
             "(in-process, 8 fixed ICs) | P < 0 | aborted | crashed | un-restored exits | orders | same optimiser "
             "in process: E[P] / P < 0 / aborted / crashed |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        table.append(f"| {r['method']} | {r['seed']} | {r['trials']} | {r['wall_s']:.0f} | {r['wall_per_trial']:.2f} | "
                     f"{r['P_base']:.3f} | {r['P_confirm']:.3f} | {r['E_best']:.3f} / {r['E_base']:.3f} | "
                     f"{r['unsafe']} | {r['aborted']} | {r['crashed']} | {r['unrestored']} | {r['orders']} | "
                     f"{r['E_inproc']:.3f} / {r['unsafe_inproc']} / {r['aborted_inproc']} / {r['crashed_inproc']} |")
    lines = ["| method | seeds | median wall (s) | re-flown P (MAVLink), median | E[P] median [min, max] (baseline) | "
             "P < 0 / aborted / crashed trials, total | same optimiser in process: E[P] median | un-restored exits |",
             "|---|---|---|---|---|---|---|---|"]
    for method in dict.fromkeys(r["method"] for r in rows):
        mine = [r for r in rows if r["method"] == method]
        med = lambda k: float(np.median([r[k] for r in mine]))  # noqa: E731
        tot = lambda k: sum(int(r[k]) for r in mine)  # noqa: E731
        e = [r["E_best"] for r in mine]
        lines.append(f"| {method} | {len(mine)} | {med('wall_s'):.0f} | {med('P_confirm'):.3f} | {med('E_best'):.3f} "
                     f"[{min(e):.3f}, {max(e):.3f}] ({med('E_base'):.3f}) | {tot('unsafe')} / {tot('aborted')} / "
                     f"{tot('crashed')} | {med('E_inproc'):.3f} | {tot('unrestored')} |")
    return "\n".join([
        f"`{command}` — {machine()}.",
        "",
        "Each campaign: `ksbo-mav sim --lockstep` in its own process, the tuner listening on UDP 127.0.0.1, "
        "prior = 36 in-process simulator episodes around the baseline (nothing flown), then the optimiser's trials "
        "(trial 0 = baseline gains) and 1 confirmation flight of the recommendation; each trial = hover short of "
        "the start, write + verify gains, 1 s settle, an approach flown with the trial's gains that passes the "
        "start at the trial's random velocity (up to 1 m/s, the task's initial conditions), 2-lap figure-8 (600 "
        "setpoints at 50 Hz simulated), restore + verify the baseline. The tuner's monitor uses the sim-planar "
        "profile's [safety] limits, which are the in-process monitor's; a trial holds its end point with its "
        "gains for 1 s more, monitored, and is watched for 1.5 s after the restore. 'Re-flown P (MAVLink)' is the "
        "confirmation flight (from its own random moving start); 'E[P]' re-flies the same gains in process over "
        "the 8 fixed initial conditions under the "
        "in-process monitor (an aborted re-flight scores below 0). 'Same optimiser in process': the same method, "
        "prior, bounds and seed on the in-process monitored simulator (random initial conditions).",
        "",
        *lines,
        "",
        "Every campaign:",
        "",
        *table,
    ])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--budget", type=int, default=60)
    ap.add_argument("--methods", nargs="+", default=["ksbo-adaptive", "ksbo"],
                    help="optimisers to compare (each flies every seed)")
    ap.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                    help="optimiser option for every campaign (VALUE is JSON), as `ksbo-mav tune --option`")
    ap.add_argument("--out", default="bench-runs/tune")
    ap.add_argument("--report", nargs="+", metavar="RESULTS_JSON",
                    help="fly nothing: write benchmarks/mavlink-campaign/results.md from these results.json files "
                         "(runs split over processes)")
    ap.add_argument("--command", help="with --report: the command line to quote in the results")
    ap.add_argument("--write", action="store_true",
                    help="write benchmarks/mavlink-campaign/results.md after flying (default: print it only)")
    args = ap.parse_args()
    if args.report:
        rows = [r for f in args.report for r in json.loads(Path(f).read_text())]
        body = report(rows, args.command or "python scripts/bench_tune_campaign.py --report ...")
        write_result("mavlink-campaign", body)
        print(body)
        return
    from ksbo_mav.cli.tune import option_arg

    from ksbo_mav.errors import InputError

    try:
        options = dict(option_arg(o) for o in args.option)  # parsed as `ksbo-mav tune --option` parses them
    except InputError as exc:
        ap.error(str(exc))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for method in args.methods:
        for seed in args.seeds:
            r = run_one(seed, args.budget, out, method, options)
            print(json.dumps(r), flush=True)
            rows.append(r)
            (out / "results.json").write_text(json.dumps(rows, indent=1))  # after each: a crash keeps the rest
    body = report(rows, f"python scripts/bench_tune_campaign.py --seeds {' '.join(map(str, args.seeds))} "
                        f"--budget {args.budget} --methods {' '.join(args.methods)}"
                        + "".join(f" --option {o}" for o in args.option))
    print(body)
    if args.write:
        write_result("mavlink-campaign", body)
    else:
        print(f"(benchmarks/ unchanged; --report {out / 'results.json'} ... writes the results)")


if __name__ == "__main__":
    main()
