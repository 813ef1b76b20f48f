"""The safe GP optimisers that differ only in their kernel: ``ksbo``, ``standard`` and ``safeopt``.

* ``ksbo`` — the paper's method: additive kernel whose orders (and optionally dimensions) are selected on the
  data available before BO (prior + start) with Algorithm 1 (C_ree), then safe BO (opt.methods.safe_bo).
* ``standard`` — the same safe BO with the usual high-dimensional additive choice, orders {1, D}.
* ``safeopt`` — SafeOpt's rule with a full SE-ARD GP (order-D additive kernel = product SE kernel).

All three share the GP prior scales, β, candidates and recommendation rule, so a difference in results is the
kernel (and, for safeopt, the acquisition rule).

By default (``safety_kernel="se"``) the additive methods do not certify safety with their own GP alone: a local
SE-ARD GP (lengthscale ``safety_lengthscale``, the safeopt model) must certify every query as well. An additive
kernel keeps a correlation of (D − r)/D when one dimension moves arbitrarily far, which on the quadrotor (cliffs
at the limit-cycle and z-loop boundaries, part D of the fact sheet) certified crashing gains; the additive GP
still drives the acquisition and the recommendation, which is where kernel selection pays (BENCHMARKS.md).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ksbo_mav.errors import UnsafeStartError
from ksbo_mav.opt.methods.build import safe_bo_for
from ksbo_mav.opt.methods.loop import run_safe_bo
from ksbo_mav.opt.methods.safe_bo import SafeBO
from ksbo_mav.opt.models.selection import KernelSelection, reselect_by_evidence, select_kernel
from ksbo_mav.opt.options import Options
from ksbo_mav.opt.evaluation import Outcome
from ksbo_mav.opt.problem import Problem, build_result
from ksbo_mav.opt.result import OptimizeResult


def _outcome_masks(problem: Problem) -> tuple[np.ndarray, np.ndarray]:
    """(n,) complete and crashed masks of ``problem.data()`` (prior rows count as complete)."""
    m = len(problem.prior_y)
    done = np.array([True] * m + [o is Outcome.COMPLETE for o in problem.outcomes], dtype=bool)
    crashed = np.array([False] * m + [o is Outcome.CRASHED for o in problem.outcomes], dtype=bool)
    return done, crashed


def run_safe_method(problem: Problem, method: str, opts: Options, seed: int | None) -> OptimizeResult:
    """Run ``ksbo`` / ``ksbo-adaptive``, ``standard`` or ``safeopt`` on ``problem`` (x0 already evaluated).

    ksbo selects its kernel on the data available before BO (prior + x0) with Algorithm 1; with ``select_at``
    = k > 0 it selects again by C_ree after k BO iterations; with ``reselect_every`` = k > 0 it re-selects by
    evidence every k iterations (``info["reselections"]`` lists each, with ``changed``).
    """
    d = problem.dim
    X, y = problem.data()
    done, crashed = _outcome_masks(problem)
    if not done.any():
        raise UnsafeStartError("no completed trial to start from: x0's trial did not complete (check_x0=False)")
    info: dict[str, Any] = {"options": opts}
    ksbo = method in ("ksbo", "ksbo-adaptive")
    if ksbo:
        sel = select_kernel(X[done], y[done], opts, opts.lengthscale, seed)
    elif method == "standard":
        sel = KernelSelection((1, d) if d > 1 else (1,), method="fixed", reason="standard: orders 1 + d")
    elif method == "safeopt":
        sel = KernelSelection((d,), method="fixed", reason="safeopt: SE-ARD")
    else:
        raise ValueError(method)
    info["selection"] = sel.as_dict()
    selections = [sel]
    rng = np.random.default_rng(seed)
    bo = safe_bo_for(problem, opts, sel.orders, sel.dims, seed, rng)
    bo.fit(X, y, done, crashed)
    every = opts.reselect_every if ksbo and opts.orders is None and sel.dims is None else 0

    def after(b: SafeBO) -> None:
        if every and b.iteration % every == 0 and b.obs.complete.sum() >= 2:
            new = reselect_by_evidence(b.model, *b.obs.gp_data(), opts, b.iteration)
            selections.append(new)
            if new.changed:
                b.surrogate.switch_orders(new.orders, b.obs)

    reselect = ksbo and opts.select_at > 0 and opts.orders is None
    log = run_safe_bo(problem, bo, max_iters=opts.select_at if reselect else None, after=after)
    if reselect and problem.remaining > 0:
        X, y = problem.data()
        done, crashed = _outcome_masks(problem)
        sel = select_kernel(X[done], y[done], opts, opts.lengthscale, seed)
        info["reselection"] = {**sel.as_dict(), "at_iteration": bo.iteration}
        fixed = opts.update({"signal_std": bo.model.signal_std, "noise_std": bo.model.noise_std})
        old = bo
        bo = safe_bo_for(problem, fixed, sel.orders, sel.dims, seed, rng)
        bo.iteration, bo.fallbacks = old.iteration, old.fallbacks
        bo.stopping = old.stopping
        bo.region.box, bo.on_grow = old.region.box, old.on_grow
        bo.fit(X, y, done, crashed)
        log += run_safe_bo(problem, bo, after=after)
    info["proposals"] = log
    if len(selections) > 1:
        info["reselections"] = [s.as_dict() for s in selections[1:]]
        info["reselection_changes"] = sum(s.changed for s in selections[1:])
    if bo.surrogate.scale.history:
        info["safety_lengthscales"] = bo.surrogate.scale.history
    if bo.trust_region is not None:
        info["trust_region"] = {"radius": bo.trust_region.radius, "history": bo.trust_region.history}
    if bo.box is not None:
        info["box"] = {"bounds": problem.to_physical(np.column_stack([bo.box.lo, bo.box.hi]).T).T.tolist(),
                       "growth": [problem.growth_record(g) for g in bo.box.history]}
    if problem.stopped and opts.max_aborts is not None and bo.obs.aborts >= opts.max_aborts:
        info["stopped"] = f"max_aborts={opts.max_aborts} reached"
    if bo.stopping is not None:
        info["stop"] = bo.stopping.summary(problem.budget)
    if bo.refly.chosen is not None:
        info["reflown"] = [problem.to_physical(bo.obs.X[i]).tolist() for i in bo.refly.chosen]
    i, mu, lcb = bo.final_choice()
    info["gp_train_y"] = (np.asarray(bo.model.gp.y_train_) + problem.p_min).tolist()  # completed trials only
    info["signal_std"] = bo.model.signal_std
    info["noise_std"] = bo.model.noise_std
    result = build_result(
        problem, method, i, mu=mu, lcb=lcb, orders=tuple(bo.model.spec.orders), dims=bo.model.spec.active_dims,
        fallbacks=bo.fallbacks, info=info,
    )
    result.selection = selections[-1]
    return result
