"""Diagnostic: does the in-process monitor turn bad flights into recovered ones (aborted) rather than
crashes? The same random gains are flown, from the same random initial conditions, under two monitors:

- ``before``: the monitor of the tenth session — box checked at the position only, backup flown through SCG's
  mixer (which loses all torque when the position loop asks for less than the minimum thrust);
- ``now``: the default — box checked at the stopping point ``p + v|v|/(2·3 m/s²)``, backup mixer with attitude
  priority (collective clamped so the torque survives, like ArduPilot's ATC_THR_MIX and PX4's airmode).

Gains: ``--n`` points per plant at a distance drawn uniformly in [0.05, 0.6] from the profile's baseline a0 in
the optimiser's unit cube (random direction, clipped to the cube) — where a safe optimiser's exploration goes.
Printed per plant: complete / aborted / crashed under each monitor, and the completes the new monitor loses
(flights that finished under the old one but are stopped now) with how many of those scored P < 0 anyway.
``--why``: for each monitor's crashes, what tripped it, which environment bound ended the flight
and how many control steps (50 Hz) lay between the trip and the crash.

    python scripts/diag/monitor_backup.py --n 1500 [--why]
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np


def monitors() -> dict[str, object]:
    from ksbo_sim.episode import MonitorConfig
    from ksbo_task.limit_checks import planar_monitor_limits

    before = MonitorConfig(limits=replace(planar_monitor_limits(), brake_accel=None), attitude_priority=False)
    return {"before": before, "now": MonitorConfig()}


def random_gains(profile, n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, d) gains at unit-cube distance U(0.05, 0.6) from the baseline, random direction, clipped to the box."""
    u0 = profile.to_unit(profile.default)
    d = rng.normal(size=(n, u0.size))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    u = np.clip(u0 + d * rng.uniform(0.05, 0.6, size=(n, 1)), 0.0, 1.0)
    return np.array([profile.from_unit(row) for row in u])


def fly(plant: str, n: int, seed: int) -> dict[str, tuple[object, np.ndarray]]:
    """Per monitor ("before", "now"): the :class:`ksbo_sim.episode.Rollout` of ``n`` random gains on ``plant`` and
    their (n,) P, the same gains and initial conditions under both."""
    from ksbo_mav.simulated.planar_objective import SimObjective
    from ksbo_mav.scoring import score_rollout
    from ksbo_sim.episode import simulate
    from ksbo_task.starts import random_initial_states

    rng = np.random.default_rng(seed)
    out: dict[str, tuple[object, np.ndarray]] = {}
    X = init = None
    for name, mon in monitors().items():
        obj = SimObjective(plant=plant, monitor=mon)
        if X is None:
            X = random_gains(obj.profile, n, rng)
            init = random_initial_states(n, rng, obj.episode.figure8)
        r = simulate(X, init, obj.episode)
        out[name] = (r, score_rollout(r, obj.score_config).P)
    return out


def plant_counts(plant: str, n: int, seed: int, flights: dict | None = None) -> dict[str, np.ndarray]:
    """Per monitor: (n,) outcome codes (0 complete, 1 aborted, 2 crashed) and (n,) P (key ``<monitor>_P``), same
    gains and starts; ``flights`` reuses a :func:`fly` result."""
    from ksbo_task.limit_checks import Outcome

    code = {Outcome.COMPLETE: 0, Outcome.ABORTED: 1, Outcome.CRASHED: 2}
    out: dict[str, np.ndarray] = {}
    for name, (r, P) in (flights or fly(plant, n, seed)).items():
        out[name] = np.array([code[o] for o in r.outcomes])
        out[name + "_P"] = P
    return out


def crash_causes(rollout) -> tuple[dict[str, int], float]:
    """The crashes of one :func:`fly` rollout: counts of "trip → crash reason" and the median number of control
    steps from the trip to the crash."""
    from collections import Counter

    from ksbo_sim.episode import REASONS
    from ksbo_task.limit_checks import TRIP_NAMES

    r = rollout
    causes: Counter[str] = Counter()
    gaps = []
    for i in np.nonzero(r.reason != 0)[0]:
        causes[f"{TRIP_NAMES[int(r.trip[i])]} → {REASONS[int(r.reason[i])]}"] += 1
        flown = np.nonzero(~np.isnan(r.states[i, :, 0]))[0]
        gaps.append(int(flown[-1]) - int(r.L[i]))
    return dict(causes.most_common()), float(np.median(gaps)) if gaps else float("nan")


def main(argv: list[str] | None = None) -> None:
    from ksbo_sim.plants import PLANTS

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1500, help="random gains per plant")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--plants", default=",".join(PLANTS))
    ap.add_argument("--why", action="store_true", help="also classify each monitor's crashes")
    a = ap.parse_args(argv)
    print("| plant | before: complete / aborted / crashed | now: complete / aborted / crashed "
          "| completes lost (of them P < 0 before) |")
    print("|---|---|---|---|")
    why = []
    for plant in a.plants.split(","):
        flights = fly(plant, a.n, a.seed)
        c = plant_counts(plant, a.n, a.seed, flights)
        b, w = c["before"], c["now"]
        lost = (b == 0) & (w != 0)
        fmt = lambda o: " / ".join(str(int((o == k).sum())) for k in range(3))  # noqa: E731
        print(f"| {plant} | {fmt(b)} | {fmt(w)} | {int(lost.sum())} ({int((lost & (c['before_P'] < 0)).sum())}) |",
              flush=True)
        if a.why:  # printed after the table, from the same flights
            for which, (r, _) in flights.items():
                causes, gap = crash_causes(r)
                why.append(f"{plant} ({which}): {sum(causes.values())} crashes, trip → crash in {gap:.0f} steps "
                           "(median): " + ", ".join(f"{k} {v}" for k, v in causes.items()))
    if why:
        print("\n".join(why))

if __name__ == "__main__":
    main()
