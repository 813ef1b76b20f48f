"""Cell kind ``timing``: seconds of one named operation, the best of ``repeats`` (default 5) after one warm-up
(numba compiles, caches fill), BLAS pinned to one thread like every cell. The seconds go to the record's
``timing`` (they differ from run to run); ``result`` holds what was timed and any figure it computed.

Key: ``what`` — one of :data:`OPERATIONS`, or of ksbo_bench.kinds.timing_processes.MEASURES (timings of whole
processes: a simulator and its client over MAVLink, scoring a 500 MB log) — and its own values (``batch``,
``gains``, ``engine``, ``n_obs``, ``method``, ``op``, ``personality``, ``columns``); ``repeats``.
"""

from __future__ import annotations

import time
from typing import Any, Callable

import numpy as np

from ksbo_bench.cell_errors import SweepError


def _planar_episode(key: dict) -> tuple[Callable[[], Any], dict]:
    from ksbo_mav.profiles import load_profile
    from ksbo_sim.scalar import simulate_one
    from ksbo_task.starts import random_initial_states

    a0, init = load_profile("sim-planar").default, random_initial_states(1, np.random.default_rng(0))[0]
    return (lambda: simulate_one(a0, init)), {"items": 1, "sim_s": 12.0}


def _planar_batch(key: dict) -> tuple[Callable[[], Any], dict]:
    """``batch`` episodes, scored, of uniform random gains in the box (``gains = "a0"``: the default gains, every
    episode flying its 600 steps); ``engine`` numpy or numba (its own threads)."""
    from ksbo_mav.profiles import load_profile
    from ksbo_mav.scoring import score_rollout
    from ksbo_sim import simulate
    from ksbo_sim.scalar import simulate_parallel
    from ksbo_task.starts import random_initial_states

    rng = np.random.default_rng(0)
    B = int(key.get("batch", 1000))
    prof = load_profile("sim-planar")
    X = np.tile(prof.default, (B, 1)) if key.get("gains") == "a0" else prof.from_unit(rng.uniform(size=(B, 9)))
    init = random_initial_states(B, rng)
    sim = simulate_parallel if key.get("engine", "numpy") == "numba" else simulate
    return (lambda: score_rollout(sim(X, init))), {"items": B}


def _ksbo_proposal(key: dict) -> tuple[Callable[[], Any], dict]:
    """One ksbo proposal with ``n_obs`` observations (9-D, orders 2, 3, 4, the paper comparison's options)."""
    from ksbo_bench.kinds.paper_methods import METHOD_OPTIONS
    from ksbo_mav.opt.methods.build import safe_bo_for
    from ksbo_mav.opt.options import options_for
    from ksbo_mav.opt.problem import Problem

    n = int(key.get("n_obs", 200))
    rng = np.random.default_rng(0)
    X = np.clip(0.3 + 0.2 * rng.random((n, 9)), 0, 1)
    opts = options_for("ksbo", METHOD_OPTIONS["ksbo"]).update({"expansion_iters": 0})
    prob = Problem(fun=lambda x: 0.0, lower=np.zeros(9), upper=np.ones(9), x0=X[0], budget=1)
    bo = safe_bo_for(prob, opts, (2, 3, 4), None, 0, rng)
    bo.fit(X, np.sin(3 * X).sum(1) / 3)
    return bo.propose, {"items": 1}


def _ksbo_update(key: dict) -> tuple[Callable[[], Any], dict]:
    """The ksbo model's update after one more observation (``n_obs`` before the first; each repeat adds one)."""
    fn, _ = _ksbo_proposal(key)
    bo = fn.__self__
    x = np.asarray(bo.propose().x, float)
    rng = np.random.default_rng(1)
    return (lambda: bo.observe(np.clip(x + 0.01 * rng.standard_normal(x.size), 0, 1), 0.5)), {"items": 1}


def _gp(key: dict) -> tuple[Callable[[], Any], dict]:
    """``op``: fit-predict (n = 116, mean and std at 4096 candidates), add-observation (fit at 115 + one rank-one
    update), ml2 (ML-II fit at l = 36: 9 lengthscales, 3 variances, noise, 3 starts); orders (2, 3, 4)."""
    from ksbo_mav.gp import AdditiveKernel, GaussianProcess

    rng = np.random.default_rng(0)
    B, X, y = rng.random((4096, 9)), rng.random((116, 9)), rng.standard_normal(116)
    k = AdditiveKernel(9, (2, 3, 4), 0.2)
    op = key.get("op", "fit-predict")
    if op == "ml2":
        return (lambda: GaussianProcess(AdditiveKernel(9, (2, 3, 4), np.full(9, 0.3)), noise=1e-2, optimize=True,
                                        n_restarts=2, seed=0).fit(X[:36], y[:36])), {"items": 1}
    if op == "add-observation":
        return (lambda: GaussianProcess(k, noise=1e-2).fit(X[:115], y[:115]).add_observation(X[115], y[115])), \
            {"items": 1}
    return (lambda: GaussianProcess(k, noise=1e-2).fit(X, y).predict(B, return_std=True)), {"items": 1}


def _cree_exact(key: dict) -> tuple[Callable[[], Any], dict]:
    from ksbo_mav.select import cree_exact, lhs_design, order_kernel_matrices

    X = lhs_design(36, 9, seed=0)
    y = np.sin(3 * X[:, 0]) * X[:, 1] + X[:, 2] * X[:, 3]
    Ks = order_kernel_matrices(X, tuple(range(1, 10)), 0.2)
    ys = (y - y.mean()) / y.std()
    return (lambda: cree_exact(Ks, ys, 0.1)), {"items": 1}


def _kernel_matrix(key: dict) -> tuple[Callable[[], Any], dict]:
    from ksbo_mav.gp import AdditiveKernel

    rng = np.random.default_rng(0)
    A, B = rng.random((200, 9)), rng.random((4096, 9))
    k = AdditiveKernel(9, (2, 3, 4), 0.2, method=key.get("method", "newton-girard"))
    return (lambda: k(A, B)), {"items": 1, "shape": [200, 4096]}


def _select_orders(key: dict) -> tuple[Callable[[], Any], dict]:
    from ksbo_mav.select import lhs_design, select_orders

    X = lhs_design(36, 9, seed=0)
    y = np.sin(3 * X[:, 0]) * X[:, 1] + X[:, 2] * X[:, 3]
    c = int(key.get("columns", 36))
    return (lambda: select_orders(X, y, trials=1000, columns=c, seed=1)), {"items": 1}


def _copter3d_flight(key: dict) -> tuple[Callable[[], Any], dict]:
    """One 40 s figure-8 of our JSBSim copter in process (the real-time factor is 40 s over the seconds)."""
    from ksbo_sim.copter3d import Copter3D, fly
    from ksbo_task.figure8_ne import Figure8H

    v = Copter3D(key.get("personality", "ardupilot"))  # ardupilot, ardupilot-legacy, px4
    return (lambda: fly(v, Figure8H()).rms_lap2), {"items": 1, "sim_s": 40.0}


OPERATIONS: dict[str, Callable[[dict], tuple[Callable[[], Any], dict]]] = {
    "planar-episode": _planar_episode, "planar-batch": _planar_batch, "ksbo-proposal": _ksbo_proposal,
    "kernel-matrix": _kernel_matrix, "select-orders": _select_orders, "copter3d-flight": _copter3d_flight,
    "ksbo-update": _ksbo_update, "gp": _gp, "cree-exact": _cree_exact,
}


def check(key: dict[str, Any]) -> None:
    from ksbo_bench.kinds.timing_processes import MEASURES

    if key["what"] not in OPERATIONS and key["what"] not in MEASURES:
        raise SweepError(f"timing: what must be one of {', '.join([*OPERATIONS, *MEASURES])}, not {key['what']!r}")


def resources(key: dict[str, Any]) -> dict[str, float]:
    from ksbo_bench.kinds.timing_processes import SITL_MEASURES

    return {"sitl": 1} if key["what"] in SITL_MEASURES else {}


def run(key: dict[str, Any], inputs: dict[str, Any] | None = None) -> dict[str, Any]:
    from ksbo_bench.kinds.timing_processes import MEASURES

    if key["what"] in MEASURES:  # timings of processes: they measure themselves
        return MEASURES[key["what"]](key)
    fn, result = OPERATIONS[key["what"]](key)
    fn()  # warm-up: compiles, caches
    times = []
    for _ in range(int(key.get("repeats", 5))):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    best = min(times)
    timing = {"seconds": best, "per_item_s": best / result["items"], "median_s": float(np.median(times))}
    if "sim_s" in result:
        timing["real_time_factor"] = result["sim_s"] / best
    return {"result": {"what": key["what"], **result}, "timing": timing}
