"""Benchmark: full tuning campaigns (simulator prior + N trials) against `ksbo-mav sim --lockstep` over UDP.

Reports wall time, the recommendation's P re-flown over MAVLink and its in-process re-flown E[P] over the fixed
initial conditions (comparable with the in-process optimiser benchmark), unsafe and aborted trials, and whether
every exit left the baseline verified on the vehicle. Writes the section "MAVLink tuning campaign (issue 7)" of
BENCHMARKS.md.

    python scripts/bench_tune_campaign.py [--seeds 0 1 2] [--budget 60] [--out bench-runs/tune]
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

from _bench_common import machine, write_section  # noqa: E402


def run_one(seed: int, budget: int, out: Path) -> dict:
    from ksbo_mav.mav.link import Endpoint
    from ksbo_mav.objective import SimObjective
    from ksbo_mav.profiles import load_profile
    from ksbo_mav.campaign import Campaign, CampaignConfig
    from ksbo_sim.process import free_udp_port
    from ksbo_sim.testing import SimProcess, read_params

    d = out / f"seed{seed}"
    shutil.rmtree(d, ignore_errors=True)
    prof = load_profile("sim-planar")
    baseline = {n: float(np.float32(x)) for n, x in zip(prof.names, prof.default)}
    port = free_udp_port()
    with SimProcess("--lockstep", out_port=port) as sim:
        t = time.monotonic()
        s = Campaign(CampaignConfig(dir=str(d), budget=budget, seed=seed, prior="sim", end="hold"),
                     Endpoint("udp", "127.0.0.1", port), log=lambda m: None).run()
        wall = time.monotonic() - t
        restored_end = read_params(sim, prof.names) == baseline  # independent plain-pymavlink read
    records = [json.loads(line) for line in (d / "journal.jsonl").read_text().splitlines()]
    sim_obj = SimObjective("sim-planar")
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
        ref = optimize(SimObjective("sim-planar", seed=seed), np.array(camp["x0"]), np.array(camp["bounds"]),
                       budget=budget, seed=seed, prior=(np.array(prior["X"]), np.array(prior["y"])),
                       **optimizer_options(prior["kind"], camp["config"].get("options", {})))
    e_ref = float(sim_obj.expected(ref.x)[0])
    return {"seed": seed, "wall_s": wall, "trials": len(records), "P_base": s["baseline"]["P"],
            "P_confirm": s["best"]["P_confirm"], "E_best": e_best, "E_base": e_base, "unsafe": s["n_unsafe"],
            "aborted": s["n_aborted"], "unrestored": sum(not r["restored"] for r in records) + (not restored_end),
            "orders": s["orders"], "wall_per_trial": wall / len(records), "E_inproc": e_ref,
            "unsafe_inproc": int(ref.n_unsafe)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--budget", type=int, default=60)
    ap.add_argument("--out", default="bench-runs/tune")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for seed in args.seeds:
        r = run_one(seed, args.budget, out)
        print(json.dumps(r), flush=True)
        rows.append(r)
    (out / "results.json").write_text(json.dumps(rows, indent=1))
    table = ["| seed | trials | wall (s) | s/trial | baseline P | re-flown P (MAVLink) | E[P] best / baseline "
             "(in-process, 8 fixed ICs) | unsafe | aborted | un-restored exits | orders | same optimiser in process: "
             "E[P] / unsafe |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        table.append(f"| {r['seed']} | {r['trials']} | {r['wall_s']:.0f} | {r['wall_per_trial']:.2f} | "
                     f"{r['P_base']:.3f} | {r['P_confirm']:.3f} | {r['E_best']:.3f} / {r['E_base']:.3f} | "
                     f"{r['unsafe']} | {r['aborted']} | {r['unrestored']} | {r['orders']} | "
                     f"{r['E_inproc']:.3f} / {r['unsafe_inproc']} |")
    med = lambda k: float(np.median([r[k] for r in rows]))  # noqa: E731
    body = "\n".join([
        f"`python scripts/bench_tune_campaign.py --seeds {' '.join(map(str, args.seeds))} --budget {args.budget}` "
        f"— {machine()}.",
        "",
        f"Each campaign: `ksbo-mav sim --lockstep` in its own process, the tuner listening on UDP 127.0.0.1, "
        f"prior = 36 in-process simulator episodes around the baseline (nothing flown), then {args.budget} "
        "optimiser trials (ksbo, trial 0 = baseline gains) and 1 confirmation flight of the recommendation; each "
        "trial = hover at the start, write + verify gains, 1 s settle, 2-lap figure-8 (600 setpoints at 50 Hz "
        "simulated), restore + verify the baseline. 'Re-flown P (MAVLink)' is the confirmation flight from a hover "
        "start; 'E[P]' re-flies the same gains in process over the 8 fixed initial conditions (the in-process "
        "benchmark's measure).",
        "",
        *table,
        "",
        f"Median: wall {med('wall_s'):.0f} s, re-flown P {med('P_confirm'):.3f}, E[P] {med('E_best'):.3f} "
        f"(baseline {med('E_base'):.3f}); same optimiser in process E[P] {med('E_inproc'):.3f}; "
        f"un-restored exits in total: {sum(r['unrestored'] for r in rows)}.",
    ])
    write_section("MAVLink tuning campaign (issue 7)", body)
    print(body)


if __name__ == "__main__":
    main()
