#!/usr/bin/env python
"""Where the good gains of the planar task lie, seen from the default gains a0 (how far safe BO from a0 must travel).

Three measurements, all in the unit cube of the sim-planar profile and with the re-flown E[P] (8 fixed initial
conditions) as the value of a gain vector:

1. Reach: the best E[P] an evolution strategy finds within distance R of a0 (R = 0.3, 0.5, 0.8, 1.2). Tells how
   far a safe optimiser must travel to reach a given value.
2. Risk around the way: along straight lines from a0 to two good points, E[P] and the share of random
   neighbours at distance r (0.03, 0.06) whose E[P] is negative. Tells how close to crashing gains a value sits.
3. Robust optimum: the best E[P] whose r-ball (r = 0.03, uniform) holds no crashing single episodes among 64
   random (neighbour, initial velocity) pairs — an upper bound for an optimiser that must not crash while it
   takes steps of that size.

    python scripts/bench_landscape.py            # ~2 min on 2 cores; writes benchmarks/landscape/results.md
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench_common import machine, write_result  # noqa: E402



def es_max(E, u0: np.ndarray, rng: np.random.Generator, radius: float, iters: int = 60,
           accept=None) -> tuple[float, np.ndarray]:
    """(1+λ) evolution strategy on ``E`` (batch of unit-cube points -> values) within ``radius`` of ``u0``.

    ``accept(u) -> bool`` is an extra constraint checked on the best few candidates of each round.
    """
    best, fb = u0.copy(), float(E(u0[None])[0])
    for it in range(iters):
        T = np.clip(best + rng.standard_normal((200, u0.size)) * 0.1 * 0.97**it, 0, 1)
        T = T[np.linalg.norm(T - u0, axis=1) <= radius]
        if len(T) == 0:
            continue
        f = E(T)
        for j in np.argsort(-f)[:6]:
            if f[j] <= fb:
                break
            if accept is None or accept(T[j]):
                fb, best = float(f[j]), T[j].copy()
                break
    return fb, best


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--no-write", action="store_true", help="print only, do not write benchmarks/landscape/results.md")
    args = ap.parse_args(argv)
    from threadpoolctl import threadpool_limits

    # loads scipy's BLAS: the limit pins only loaded libraries
    from ksbo_mav.simulated.planar_objective import SimObjective
    from ksbo_mav.profiles import load_profile

    threadpool_limits(1)
    from ksbo_task.starts import random_initial_states

    t0 = time.time()
    prof = load_profile("sim-planar")
    obj = SimObjective(prof, seed=0)
    u0 = prof.to_unit(prof.default)

    def E(U: np.ndarray) -> np.ndarray:
        return obj.expected(prof.from_unit(np.clip(U, 0, 1)))

    lines = [f"Machine: {machine()}. Script: `python scripts/bench_landscape.py`. Unit cube of the sim-planar "
             "profile; value = re-flown E[P] over the 8 fixed initial conditions; a0 = the default gains (0.198).",
             "", "**Reach** — best E[P] found by a (1+200) evolution strategy (60 rounds) within distance R of a0:",
             "", "| R | best E[P] | its distance from a0 |", "|---|---|---|"]
    rng = np.random.default_rng(0)
    goods = {}
    for R in (0.3, 0.5, 0.8, 1.2):
        fb, ub = es_max(E, u0, rng, R)
        goods[R] = ub
        lines.append(f"| {R} | {fb:.3f} | {np.linalg.norm(ub - u0):.2f} |")

    lines += ["", "**Risk along the way** — straight lines from a0 to the R = 0.5 and R = 0.8 points above; share "
              "of 200 random neighbours at distance r with E[P] < 0 (one crashing initial condition in 8 is "
              "enough for a negative mean only if it crashes early, so this undercounts single-episode risk):", "",
              "| line | t | E[P] | unsafe neighbours r = 0.03 | r = 0.06 |", "|---|---|---|---|---|"]
    for R in (0.5, 0.8):
        for t in np.linspace(0.0, 1.0, 6):
            u = u0 + t * (goods[R] - u0)
            e = float(E(u[None])[0])
            share = []
            for r in (0.03, 0.06):
                D = rng.standard_normal((200, u.size))
                D /= np.linalg.norm(D, axis=1, keepdims=True)
                share.append(float(np.mean(E(u + r * D) < 0)))
            lines.append(f"| a0 → R {R} | {t:.1f} | {e:.3f} | {share[0]:.2f} | {share[1]:.2f} |")

    def crash_free(u: np.ndarray, r: float = 0.03, n: int = 64) -> bool:
        D = rng.standard_normal((n, u.size))
        D /= np.linalg.norm(D, axis=1, keepdims=True)
        N = np.clip(u + r * rng.random((n, 1)) ** (1 / u.size) * D, 0, 1)
        s = obj.scores(prof.from_unit(N), random_initial_states(n, rng, obj.episode.figure8))
        return bool(np.all(s.P >= 0))

    lines += ["", "**Robust optimum** — best E[P] whose 0.03-ball showed no crashing episode in 64 random "
              "(neighbour, initial velocity) draws when accepted (evolution strategy, 80 rounds, three restarts):",
              "", "| restart | E[P] | distance from a0 | gains (unit cube) |", "|---|---|---|---|"]
    for k in range(3):
        fb, ub = es_max(E, u0, np.random.default_rng(100 + k), 2.0, iters=80, accept=crash_free)
        lines.append(f"| {k} | {fb:.3f} | {np.linalg.norm(ub - u0):.2f} | {np.round(ub, 3).tolist()} |")
    lines += ["", f"Run time {time.time() - t0:.0f} s."]
    body = "\n".join(lines)
    print(body)
    if not args.no_write:
        write_result("landscape", body)
    return 0


if __name__ == "__main__":
    sys.exit(main())
