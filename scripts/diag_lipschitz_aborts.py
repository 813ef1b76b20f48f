"""Issue 13 diagnostic (item AN): where LoSBO's aborted trials lie, and what a Lipschitz bound would have to be.

Runs ``ksbo`` with the ``lipschitz`` option (LoSBO's safe set, ``ksbo_mav.opt.lipschitz``) on a planar plant under
the in-process monitor, as ``bench_plants.py run --opt lipschitz=L`` does, and for every aborted or crashed trial
prints how far it lay (unit cube) from the nearest completed trial flown before it, what that neighbour scored, and
how often the aborted gains fail when re-flown from 100 random starts. A bound ``y − L d`` that certified the
aborted gains from that neighbour was wrong there: the pair implies a constant of at least
(y_neighbour − y_failed) / d.

    python scripts/diag_lipschitz_aborts.py [--plant nominal] [--seeds 100 104] [--L 16] [--starts 100]
"""

from __future__ import annotations

import argparse

import numpy as np


def aborted_trials(plant: str, seed: int, L: float, n_starts: int) -> list[dict[str, float]]:
    """One 100-flight ``ksbo`` run with ``lipschitz=L``: per failed trial its distance to the nearest earlier
    completed trial, both trials' P (a failed flight's as recorded, below p_min), the Lipschitz constant the pair
    implies and the failures over ``n_starts`` re-flights."""
    import ksbo_mav
    from ksbo_mav.objective import SimObjective
    from ksbo_sim.episode import random_initial_states

    obj = SimObjective(seed=seed, plant=plant, monitor=True)
    r = ksbo_mav.optimize(obj, obj.profile.default, obj.profile.bounds, budget=100, method="ksbo", seed=seed,
                          y_max=1.0, lipschitz=L)
    U = np.array([obj.profile.to_unit(x) for x in r.X])
    failed = np.array([o != "complete" for o in r.outcomes])
    judge = SimObjective(seed=999, plant=plant, monitor=True)
    rows = []
    for i in np.flatnonzero(failed):
        earlier = np.flatnonzero(~failed[:i])
        d = np.linalg.norm(U[earlier] - U[i], axis=1)
        j = int(earlier[np.argmin(d)])
        inits = random_initial_states(n_starts, np.random.default_rng(i), judge.episode)
        _, outs = judge.scores(np.repeat(r.X[i][None], n_starts, axis=0), inits, with_outcomes=True)
        fails = sum(o.value != "complete" for o in outs)
        dist = max(float(d.min()), 1e-12)
        rows.append({"trial": int(i), "outcome": r.outcomes[i], "distance": dist, "neighbour_P": float(r.y[j]),
                     "P": float(r.y[i]), "implied_L": float((r.y[j] - r.y[i]) / dist), "fails": int(fails)})
    return rows


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--plant", default="nominal", help="planar suite plant (ksbo_sim.plants)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[100, 104], help="run seeds (tuning seeds: 100+)")
    ap.add_argument("--L", type=float, default=16.0, help="the lipschitz option's constant (unit cube)")
    ap.add_argument("--starts", type=int, default=100, help="random starts each aborted gain set is re-flown from")
    a = ap.parse_args(argv)
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)
    print(f"{a.plant}, ksbo --option lipschitz={a.L:g}: failed trials, the nearest completed trial before each, "
          f"failures over {a.starts} random starts\n")
    print("| seed | trial | outcome | P | distance | neighbour's P | implied L ≥ | fails |")
    print("|---|---|---|---|---|---|---|---|")
    for seed in a.seeds:
        for row in aborted_trials(a.plant, seed, a.L, a.starts):
            print(f"| {seed} | {row['trial']} | {row['outcome']} | {row['P']:.3f} | {row['distance']:.3f} "
                  f"| {row['neighbour_P']:.3f} | {row['implied_L']:.0f} | {row['fails']} / {a.starts} |")


if __name__ == "__main__":
    main()
