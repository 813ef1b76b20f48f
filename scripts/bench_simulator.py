"""Benchmark of the planar simulator: single-episode latency and batched throughput.

Goals: one 12 s episode <= 10 ms single-threaded; <= 0.1 ms per episode batched over >= 1000 gain
vectors. BLAS is pinned to one thread. Writes benchmarks/simulator/results.md.

    python scripts/bench_simulator.py [--no-write]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench_common import machine, write_result  # noqa: E402

from ksbo_mav.simulated.planar_objective import SimObjective  # noqa: E402
from ksbo_mav.profiles import load_profile  # noqa: E402
from ksbo_mav.scoring import score_rollout  # noqa: E402
from ksbo_sim import simulate  # noqa: E402
from ksbo_sim.scalar import simulate_one, simulate_parallel  # noqa: E402
from ksbo_task.starts import random_initial_states  # noqa: E402


def best_of(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-write", action="store_true", help="print only, do not write benchmarks/simulator/results.md")
    args = ap.parse_args()
    prof = load_profile("sim-planar")
    rng = np.random.default_rng(0)
    a0 = prof.default
    init1 = random_initial_states(1, rng)[0]
    rows = []
    # BLAS pinned to 1 thread; the numba backend uses its own thread pool (2 threads on this machine).
    with threadpool_limits(1):
        simulate_one(a0, init1)  # numba compile (cached on disk afterwards)
        t_one = best_of(lambda: simulate_one(a0, init1), 20)
        t_np1 = best_of(lambda: simulate(a0, init1), 5)
        rows.append(("single episode, compiled scalar path (`simulate_one`)", f"{t_one * 1e3:.3f} ms",
                     f"{12.0 / t_one:,.0f}x real time"))
        rows.append(("single episode, numpy batched path at B = 1", f"{t_np1 * 1e3:.1f} ms", f"{12.0 / t_np1:,.0f}x"))
        for B, label in ((1000, "a0 (all fly 600 steps)"), (1000, "uniform random gains in the box"),
                         (20000, "uniform random gains in the box")):
            X = np.tile(a0, (B, 1)) if label.startswith("a0") else prof.from_unit(rng.uniform(size=(B, 9)))
            init = random_initial_states(B, rng)
            t = best_of(lambda: score_rollout(simulate(X, init)), 2 if B <= 1000 else 1)
            rows.append((f"numpy batched, B = {B}, {label}, incl. scoring", f"{t / B * 1e3:.3f} ms/episode",
                         f"{t:.2f} s total"))
            simulate_parallel(X[:2], init[:2])  # compile
            t = best_of(lambda: score_rollout(simulate_parallel(X, init)), 2 if B <= 1000 else 1)
            rows.append((f"numba parallel (2 threads), B = {B}, {label}, incl. scoring",
                         f"{t / B * 1e3:.3f} ms/episode", f"{t:.2f} s total"))
        obj = SimObjective(prof, seed=1)
        X = prof.from_unit(rng.uniform(size=(20000, 9)))
        P = obj.batch(X)
        full = obj.scores(X, random_initial_states(20000, rng)).complete.mean()
    stats = (f"uniform box, 20000 gain vectors: safe fraction {np.mean(P >= 0):.3f}, full-episode fraction {full:.3f}, "
             f"P quantiles 50/90/99/100 %: " + " / ".join(f"{q:.3f}" for q in np.quantile(P, [.5, .9, .99, 1.0])))
    ep = obj.expected(np.stack([a0, prof.preset("scg"),
                                np.array([0.2367, 0.007699, 0.8752, 3, 0.000393, 2.662, 1.167e4, 88.22, 9777])]))
    table = "\n".join(f"| {a} | {b} | {c} |" for a, b, c in rows)
    load = os.getloadavg()[0]
    body = f"""Machine: {machine()}; 1-min load average at the end {load:.1f} (other work shared the 2 cores).
Script: `python scripts/bench_simulator.py` (BLAS pinned to 1 thread).
Goals: single episode <= 10 ms; batched <= 0.1 ms/episode over >= 1000 gain vectors.

| case | time | note |
|---|---|---|
{table}

Task statistics (fact-sheet values in brackets): {stats} [0.153 / 0.289; -0.990 / 0.247 / 0.808 / 0.967].
Re-flown E[P] over the 8 fixed initial conditions: a0 {ep[0]:.4f} [0.197], SCG gains {ep[1]:.4f} [0.362],
fact-sheet oracle {ep[2]:.4f} [0.966].
"""
    print(body)
    if not args.no_write:
        write_result("simulator", body)


if __name__ == "__main__":
    main()
