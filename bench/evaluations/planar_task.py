"""Evaluation ``planar-task``: the paper's planar task seen over the whole gain box, beside the task fact sheet's
values: of ``n`` (default 20,000) uniform random gain vectors (``seed``), the share that flies safely (P >= 0),
the share that completes the episode, the quantiles of P; and the re-flown E[P] (8 fixed initial conditions) of
the default gains a0, the SCG gains and the fact sheet's oracle."""

from __future__ import annotations

from typing import Any

import numpy as np

#: The task fact sheet's values (shared/docs), shown beside the measured ones.
FACT_SHEET = {"safe_fraction": 0.153, "complete_fraction": 0.289, "P_q50": -0.990, "P_q90": 0.247, "P_q99": 0.808,
              "P_max": 0.967, "EP_a0": 0.197, "EP_scg": 0.362, "EP_oracle": 0.966}
ORACLE = [0.2367, 0.007699, 0.8752, 3, 0.000393, 2.662, 1.167e4, 88.22, 9777]


def run(key: dict[str, Any]) -> dict[str, Any]:
    from ksbo_mav.profiles import load_profile
    from ksbo_mav.simulated.planar_objective import SimObjective
    from ksbo_task.starts import random_initial_states

    prof = load_profile("sim-planar")
    rng = np.random.default_rng(int(key.get("seed", 0)))
    n = int(key.get("n", 20000))
    obj = SimObjective(prof, seed=int(key.get("seed", 0)) + 1)
    X = prof.from_unit(rng.uniform(size=(n, 9)))
    P = obj.batch(X)
    full = float(obj.scores(X, random_initial_states(n, rng)).complete.mean())
    q = np.quantile(P, [0.5, 0.9, 0.99, 1.0])
    ep = obj.expected(np.stack([prof.default, prof.preset("scg"), np.array(ORACLE)]))
    return {"n": n, "safe_fraction": float(np.mean(P >= 0)), "complete_fraction": full, "P_q50": float(q[0]),
            "P_q90": float(q[1]), "P_q99": float(q[2]), "P_max": float(q[3]), "EP_a0": float(ep[0]),
            "EP_scg": float(ep[1]), "EP_oracle": float(ep[2])}


LABELS = {"safe_fraction": "share of uniform gain vectors flying safely (P >= 0)",
          "complete_fraction": "share completing the episode", "P_q50": "P, median", "P_q90": "P, 90 % quantile",
          "P_q99": "P, 99 % quantile", "P_max": "P, best", "EP_a0": "re-flown E[P] of a0 (default gains)",
          "EP_scg": "re-flown E[P] of the SCG gains", "EP_oracle": "re-flown E[P] of the fact sheet's oracle"}


def report(recs: list[dict[str, Any]]) -> str:
    r = recs[-1]["result"]
    rows = [f"| {LABELS[k]} | {r[k]:.3f} | {v:.3f} |" for k, v in FACT_SHEET.items()]
    return "\n".join([f"**The planar task over the box** ({r['n']:,} uniform random gain vectors; the fact sheet's "
                      "values beside)", "", "| quantity | measured | fact sheet |", "|---|---|---|", *rows])
