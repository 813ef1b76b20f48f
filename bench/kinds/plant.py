"""Cell kind ``plant``: safe BO run in process on a plant of the suite — the planar task or one of its variants
(ksbo_sim.plants; in ``mode`` monitor or strict) or the JSBSim copter (``copter3d-ardupilot``, ``copter3d-px4``;
always monitored, deterministic) — then its recommendation re-flown: planar on the plant's 8 fixed initial
conditions in the run's mode (a re-flight may abort or crash), copter once. E[P] is the mean re-flown P.

Key: ``plant``, ``method``, ``seed``, ``budget``; optional ``mode`` (monitor), ``n_prior`` (0: from a0; else that many
prior flights, over the whole box by LHS, or around the baseline with ``local_prior = true``, as
`tune --prior local` flies), ``options`` (a table of optimiser options).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ksbo_bench.cell_errors import SweepError


def check(key: dict[str, Any]) -> None:
    from ksbo_mav.simulated.copter_objective import COPTER_PLANTS
    from ksbo_sim.plants import PLANTS

    if key["plant"] not in PLANTS and key["plant"] not in COPTER_PLANTS:
        raise SweepError(f"unknown plant {key['plant']!r}; known: {', '.join([*PLANTS, *COPTER_PLANTS])}")
    if key.get("mode", "monitor") not in ("monitor", "strict"):
        raise SweepError(f"mode must be monitor or strict, not {key['mode']!r}")


def objective(plant: str, seed: int, monitor: bool):
    """(objective, x0 (d,), bounds (d, 2)) of a suite plant."""
    from ksbo_mav.simulated.copter_objective import COPTER_PLANTS, CopterObjective
    from ksbo_mav.simulated.planar_objective import SimObjective

    if plant in COPTER_PLANTS:
        obj = CopterObjective(plant)
        return obj, obj.baseline, obj.bounds
    obj = SimObjective(seed=seed, plant=plant, monitor=monitor)
    return obj, obj.profile.default, obj.profile.bounds


def _prior(obj, x0, bounds, n: int, seed: int, local: bool):
    from scipy.stats import qmc

    if local:  # what `ksbo-mav tune --prior local` flies: around the baseline
        from ksbo_mav.campaign.prior import local_prior_design

        X = local_prior_design(n, x0, bounds, seed)
    else:  # the paper setting: over the whole box
        lo, hi = bounds[:, 0], bounds[:, 1]
        X = lo + qmc.LatinHypercube(d=len(lo), seed=seed).random(n) * (hi - lo)
    y = np.array([f if isinstance(f, float) else (f.value if f.value is not None else -1.0) for f in map(obj, X)])
    return X, y


def run(key: dict[str, Any], inputs: dict[str, Any] | None = None) -> dict[str, Any]:
    import ksbo_mav
    from ksbo_mav.campaign.config import profile_defaults

    plant, method, seed, budget = key["plant"], key["method"], key["seed"], key["budget"]
    mode, n_prior, options = key.get("mode", "monitor"), key.get("n_prior", 0), dict(key.get("options", {}))
    obj, x0, bounds = objective(plant, seed, mode == "monitor")
    prior = _prior(obj, x0, bounds, n_prior, seed, key.get("local_prior", False)) if n_prior else None
    # the profile's implied options (backup_beta where the backup covers the trials), as `ksbo-mav tune` applies
    r = ksbo_mav.optimize(obj, x0, bounds, budget=budget, method=method, seed=seed, prior=prior, y_max=1.0,
                          **{**profile_defaults(method, obj.profile), **options})
    judge = obj if hasattr(obj, "rms_ref") else type(obj)(plant=plant, monitor=mode == "monitor")  # fixed starts
    P, counts = judge.expected_outcomes(r.x)
    props = r.info.get("proposals", [])
    result = {
        "EP": float(P[0]), "reflown_counts": counts[0].tolist(), "x": r.x.tolist(), "orders": list(r.orders or ()),
        "reselection_changes": r.info.get("reselection_changes"), "stopped": r.info.get("stopped"),
        "proposal_kinds": [p["kind"] for p in props], "first_unsafe_at": [i for i, v in enumerate(r.y) if v < 0][:10],
        "stop": ({k: r.info["stop"][k] for k in ("stopped", "after", "saved", "min_evals", "patience", "ratio")}
                 if "stop" in r.info else None),  # the stopping rule (options.early_stop = true)
    }
    if hasattr(obj, "rms_ref"):  # copter: the re-flown recommendation's RMS change against the baseline
        result["rms_ref"] = obj.rms_ref
        result["rms_change"] = float((1.0 - P[0]) * obj.ratio - 1.0) if np.isfinite(P[0]) else None
        result["best_flown_change"] = float((1.0 - np.max(r.y)) * obj.ratio - 1.0)
    n_prior_unsafe = int(np.sum(prior[1] < 0)) if prior else 0
    return {
        "flights": {"total": n_prior + r.nfev, "prior": n_prior, "search": r.nfev, "reflown": int(counts[0].sum())},
        "safety": {"crashed": r.n_crashed, "aborted": r.n_aborted, "interrupted": 0, "unsafe": r.n_unsafe,
                   "prior_unsafe": n_prior_unsafe},
        "result": result,
        "timing": {"s_per_iter": float(np.mean(r.seconds[1:])) if r.nfev > 1 else 0.0,
                   "s_per_iter_last20": float(np.mean(r.seconds[-20:])) if r.nfev > 20 else None},
    }
