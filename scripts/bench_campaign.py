#!/usr/bin/env python
"""Safe BO benchmark campaign on the planar simulator (the paper's comparison): methods × seeds × settings.

Settings:
  paper    36-point uniform LHS prior over the whole box (flown in the simulator; its unsafe points are reported
           separately), then 150 evaluations (LineBO 200) starting with the default gains a0.
  vehicle  a0 plus a small local LHS prior around a0 (``--local-n`` points within ``--local-radius`` of a0 in the
           unit cube), all flown and *counted in the 100-evaluation budget*.

Every run writes one JSON file (resumable: existing files are skipped) with the evaluations, the re-flown E[P]
and J^Q of the recommendation over the 8 fixed initial conditions, unsafe counts and optimiser seconds. Runs go
to 2 worker processes with BLAS pinned to one thread. Afterwards ``bench_campaign_report.py`` aggregates the runs
into OUT/summary.md (``scripts/benchmarks_page.py`` takes BENCHMARKS.md's headline from it; the hand-written
observations live in benchmarks/notes/safe-bo-campaign.md) and draws the figures; ``bench_campaign_overhead.py``
times one proposal.

    python scripts/bench_campaign.py --settings vehicle paper --seeds 10          # run (resumable), then report
    python scripts/bench_campaign.py --report                                      # tables + figures only
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from _bench_campaign_common import METHOD_OPTIONS, VARIANTS, parser

#: ksbo per setting: the vehicle setting selects again after 25 BO iterations (its prior is a tiny local cloud).
KSBO_SETTING = {"vehicle": {"select_at": 25}, "paper": {}}


def task_seed(seed: int) -> int:
    """Objective seed of campaign seed ``seed`` (the same for every method: same noise stream, same prior)."""
    return 10_000 + seed


def make_prior(setting: str, seed: int, prof, obj, args) -> tuple[np.ndarray, np.ndarray]:
    """Prior design of ``setting`` (physical gains (m, 9), flown values (m,)), seed-shared across methods."""
    from scipy.stats import qmc

    rng = np.random.default_rng(task_seed(seed) + 1)
    if setting == "paper":
        U = qmc.LatinHypercube(d=9, seed=rng).random(36)
    else:
        if args.local_n == 0:
            return np.zeros((0, 9)), np.zeros(0)
        u0 = prof.to_unit(prof.default)
        U = np.clip(u0 + (2 * qmc.LatinHypercube(d=9, seed=rng).random(args.local_n) - 1) * args.local_radius, 0, 1)
    X = prof.from_unit(U)
    return X, obj.batch(X)


def refly(obj, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Re-fly gains X (n, 9) over the 8 fixed initial conditions: E[P], mean J^Q, crashed re-flights (each (n,))."""
    from ksbo_task.starts import fixed_initial_states

    inits = fixed_initial_states(figure8=obj.episode.figure8)
    n, m = X.shape[0], inits.shape[0]
    s = obj.scores(np.repeat(X, m, axis=0), np.tile(inits, (n, 1)))
    P = s.P.reshape(n, m)
    done = np.asarray(s.complete, bool).reshape(n, m)
    jq = np.where(done, s.JQ.reshape(n, m), 0.0).sum(1) / np.maximum(done.sum(1), 1)
    jq = np.where(done.any(1), jq, np.nan)
    return P.mean(1), jq, (~done).sum(1)


def run_one(setting: str, method: str, seed: int, args_d: dict) -> dict:
    """One campaign run (in a worker process). Returns the JSON record."""
    from threadpoolctl import threadpool_limits

    import ksbo_mav  # loads scipy's BLAS: threadpool_limits pins only libraries already loaded
    from ksbo_mav.jsonio import jsonable
    from ksbo_mav.simulated.planar_objective import SimObjective
    from ksbo_mav.profiles import load_profile

    threadpool_limits(1)

    args = argparse.Namespace(**args_d)
    prof = load_profile("sim-planar")
    obj = SimObjective(prof, seed=task_seed(seed))
    pX, py = make_prior(setting, seed, prof, obj, args)
    if setting == "paper":
        budget = 200 if method == "linebo" else 150
        counted = 0
    else:
        budget = 100 - len(py)
        counted = len(py)
    name = method
    method, extra = VARIANTS.get(name, (name, {}))
    opts = dict(METHOD_OPTIONS[method])
    if method == "ksbo":
        opts.update(KSBO_SETTING[setting])
    opts.update(extra)
    if "orders" in opts:
        opts.pop("select_at", None)
    t0 = time.perf_counter()
    res = ksbo_mav.optimize(obj, prof.default, prof.bounds, budget=budget, method=method,
                            prior=(pX, py) if len(py) else None, seed=seed, **opts)
    wall = time.perf_counter() - t0
    E, JQ, crashed = refly(obj, np.vstack([res.x, prof.default]))
    # J^Q is only defined for complete flights (crashed ones are scored by L); NaN if every re-flight crashed.
    # All flights in order: the counted prior (vehicle setting) then the optimiser's evaluations.
    flights = np.concatenate([py, res.y]) if counted else res.y
    return {
        "setting": setting, "method": name, "seed": seed, "budget": budget, "n_prior": int(len(py)),
        "prior_counted": bool(counted), "prior_unsafe": int(np.sum(py < 0)), "prior_y": py.tolist(),
        "y": res.y.tolist(), "flights": flights.tolist(),
        "n_unsafe": int(res.n_unsafe), "unsafe_flights": int(np.sum(flights < 0)),
        "best_observed": float(np.max(flights)), "x": res.x.tolist(), "fun": float(res.fun),
        "E": float(E[0]), "JQ": float(JQ[0]), "crashed_reflights": int(crashed[0]),
        "E_a0": float(E[1]), "JQ_a0": float(JQ[1]),
        "JR_improvement": float((JQ[1] - JQ[0]) / JQ[1]),
        "orders": list(res.orders) if res.orders else None, "dims": list(res.dims) if res.dims else None,
        "selection": jsonable(res.info.get("selection")),
        "reselection": jsonable(res.info.get("reselection")),
        # the evidence re-selections of ksbo (every reselect_every iterations) and how many changed the orders
        "reselections": jsonable(res.info.get("reselections")),
        "reselection_changes": res.info.get("reselection_changes"),
        "seconds": res.seconds.tolist(), "s_per_iter": float(np.mean(res.seconds[1:])) if res.nfev > 1 else 0.0,
        "fallbacks": int(res.fallbacks), "wall": wall, "options": opts,
    }


def path_of(out: Path, setting: str, method: str, seed: int) -> Path:
    return out / setting / f"{method}_seed{seed:02d}.json"


def run_campaign(args) -> None:
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    seeds = range(args.seed_offset, args.seed_offset + args.seeds)
    tasks = [(s, m, k) for s in args.settings for k in seeds for m in args.methods
             if not path_of(args.out, s, m, k).exists()]
    log = open(args.out / "campaign.log", "a")
    print(f"{len(tasks)} runs to do ({args.workers} workers)", file=log, flush=True)
    args_d = {"local_n": args.local_n, "local_radius": args.local_radius}
    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn()) as bar:
        tid = bar.add_task("campaign", total=len(tasks))
        with ProcessPoolExecutor(args.workers) as ex:
            futs = {ex.submit(run_one, s, m, k, args_d): (s, m, k) for s, m, k in tasks}
            for f in as_completed(futs):
                s, m, k = futs[f]
                try:
                    rec = f.result()
                except Exception as exc:  # keep the campaign going; the run is retried next time
                    print(f"FAILED {s} {m} {k}: {exc!r}", file=log, flush=True)
                    bar.advance(tid)
                    continue
                p = path_of(args.out, s, m, k)
                p.parent.mkdir(parents=True, exist_ok=True)
                p.write_text(json.dumps(rec))
                print(f"{datetime.now(timezone.utc):%H:%M:%S} {s} {m} seed {k}: E {rec['E']:.3f} "
                      f"unsafe {rec['unsafe_flights']} s/it {rec['s_per_iter']:.3f} wall {rec['wall']:.0f}s",
                      file=log, flush=True)
                bar.update(tid, advance=1, description=f"{s} {m} {k}")


def main(argv: list[str] | None = None) -> int:
    args = parser(__doc__).parse_args(argv)
    args.out = args.out.resolve()
    args.out.mkdir(parents=True, exist_ok=True)
    if not args.report:
        run_campaign(args)
    from bench_campaign_report import report  # this script's directory is on sys.path when run as a script

    report(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
