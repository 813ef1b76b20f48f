"""Cell kind ``paper``: the paper's comparison on the planar task, one method and seed in one setting.

Settings: ``paper`` — a 36-point uniform LHS prior over the whole box (flown, its unsafe points counted apart), then
150 evaluations (LineBO 200) from a0; ``vehicle`` — a0 plus a small local LHS prior around it (``local_n`` points
within ``local_radius`` of a0 in the unit cube, default 8 and 0.01), flown and counted in the 100 flights. Every
method of a seed sees the same objective noise stream and the same prior (objective seed 10 000 + seed). The
recommendation and a0 are re-flown over the 8 fixed initial conditions: E[P] and J^Q.

Key: ``setting``, ``method`` (a method or an ablation of ksbo_bench.kinds.paper_methods), ``seed``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ksbo_bench.cell_errors import SweepError
from ksbo_bench.kinds.paper_methods import ALL_NAMES, METHOD_OPTIONS, VARIANTS

#: ksbo per setting: the vehicle setting selects again after 25 BO iterations (its prior is a tiny local cloud).
KSBO_SETTING = {"vehicle": {"select_at": 25}, "paper": {}}


def check(key: dict[str, Any]) -> None:
    if key["setting"] not in KSBO_SETTING:
        raise SweepError(f"setting must be vehicle or paper, not {key['setting']!r}")
    if key["method"] not in ALL_NAMES:
        raise SweepError(f"method {key['method']!r} is not one of {', '.join(ALL_NAMES)}")


def task_seed(seed: int) -> int:
    """Objective seed of campaign seed ``seed`` (the same for every method: same noise stream, same prior)."""
    return 10_000 + seed


def make_prior(key: dict[str, Any], prof, obj) -> tuple[np.ndarray, np.ndarray]:
    from scipy.stats import qmc

    rng = np.random.default_rng(task_seed(key["seed"]) + 1)
    if key["setting"] == "paper":
        U = qmc.LatinHypercube(d=9, seed=rng).random(36)
    else:
        n, radius = key.get("local_n", 8), key.get("local_radius", 0.01)
        if n == 0:
            return np.zeros((0, 9)), np.zeros(0)
        u0 = prof.to_unit(prof.default)
        U = np.clip(u0 + (2 * qmc.LatinHypercube(d=9, seed=rng).random(n) - 1) * radius, 0, 1)
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
    return P.mean(1), np.where(done.any(1), jq, np.nan), (~done).sum(1)


def run(key: dict[str, Any], inputs: dict[str, Any] | None = None) -> dict[str, Any]:
    import ksbo_mav
    from ksbo_mav.jsonio import jsonable
    from ksbo_mav.profiles import load_profile
    from ksbo_mav.simulated.planar_objective import SimObjective

    setting, name, seed = key["setting"], key["method"], key["seed"]
    prof = load_profile("sim-planar")
    obj = SimObjective(prof, seed=task_seed(seed))
    pX, py = make_prior(key, prof, obj)
    counted = setting == "vehicle" and len(py) > 0
    budget = (200 if name == "linebo" else 150) if setting == "paper" else 100 - len(py)
    method, extra = VARIANTS.get(name, (name, {}))
    opts = {**METHOD_OPTIONS[method], **(KSBO_SETTING[setting] if method == "ksbo" else {}), **extra}
    if "orders" in opts:
        opts.pop("select_at", None)
    res = ksbo_mav.optimize(obj, prof.default, prof.bounds, budget=budget, method=method,
                            prior=(pX, py) if len(py) else None, seed=seed, **opts)
    E, JQ, crashed = refly(obj, np.vstack([res.x, prof.default]))
    # every flight in order: the counted prior (vehicle setting) then the optimiser's evaluations
    flights = np.concatenate([py, res.y]) if counted else res.y
    result = {
        "budget": budget, "prior_counted": bool(counted), "prior_y": py.tolist(), "y": res.y.tolist(),
        "best_observed": float(np.max(flights)), "x": res.x.tolist(), "fun": float(res.fun),
        "E": float(E[0]), "JQ": float(JQ[0]), "crashed_reflights": int(crashed[0]), "E_a0": float(E[1]),
        "JQ_a0": float(JQ[1]), "JR_improvement": float((JQ[1] - JQ[0]) / JQ[1]),
        "orders": list(res.orders) if res.orders else None, "dims": list(res.dims) if res.dims else None,
        "selection": jsonable(res.info.get("selection")), "reselection": jsonable(res.info.get("reselection")),
        "reselections": jsonable(res.info.get("reselections")),
        "reselection_changes": res.info.get("reselection_changes"), "fallbacks": int(res.fallbacks),
        "options": jsonable(opts),
    }
    return {"flights": {"total": len(flights), "prior": int(len(py)), "search": int(res.nfev),
                        "reflown": 16},
            "safety": {"crashed": int(res.n_crashed), "aborted": int(res.n_aborted), "interrupted": 0,
                       "unsafe": int(np.sum(flights < 0)), "prior_unsafe": int(np.sum(py < 0)),
                       "optimiser_unsafe": int(res.n_unsafe)},
            "result": result,
            "timing": {"seconds": res.seconds.tolist(),
                       "s_per_iter": float(np.mean(res.seconds[1:])) if res.nfev > 1 else 0.0}}
