"""The safe GP optimisers that differ only in their kernel: ``ksbo``, ``standard`` and ``safeopt``.

* ``ksbo`` — the paper's method: additive kernel whose orders (and optionally dimensions) are selected on the
  data available before BO (prior + start) with Algorithm 1 (C_ree), then safe BO (opt.safe_bo).
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

from dataclasses import fields
from typing import Any

import numpy as np

from ksbo_mav.opt.model import ModelSpec, SafetyModel, active_mask
from ksbo_mav.opt.options import Options
from ksbo_mav.opt.problem import Problem, build_result
from ksbo_mav.opt.result import OptimizeResult
from ksbo_mav.opt.safe_bo import SafeBO, SafeBOConfig, run_safe_bo


def bo_config(opts: Options) -> SafeBOConfig:
    """The :class:`SafeBOConfig` part of ``opts`` (fields of the same name; the rest keep their defaults)."""
    shared = {f.name: getattr(opts, f.name) for f in fields(SafeBOConfig) if hasattr(opts, f.name)}
    shared["local_scales"] = tuple(shared["local_scales"])
    return SafeBOConfig(**shared)


def model_spec(opts: Options, orders: tuple[int, ...], active_dims: tuple[int, ...] | None = None) -> ModelSpec:
    """The :class:`ModelSpec` part of ``opts`` with the given kernel orders."""
    return ModelSpec(
        orders=tuple(int(r) for r in orders),
        lengthscale=opts.lengthscale,
        signal_std=opts.signal_std,
        signal_scale=opts.signal_scale,
        noise_std=opts.noise_std,
        noise_ratio=opts.noise_ratio,
        active_dims=active_dims,
        optimize=opts.optimize_hypers,
        dropped_in_order1=opts.dropped == "order1",
    )


def select_kernel(X: np.ndarray, y: np.ndarray, opts: Options, seed: int | None) -> dict[str, Any]:
    """Kernel selection on the data available before BO: orders by C_ree, then optional dimension selection.

    Returns a dict with ``orders`` (best first), ``dims`` (sorted union of kept dimensions or None = all) and the
    selection tables for the result's ``info``.
    """
    d = X.shape[1]
    if opts.orders is not None:
        return {"orders": tuple(opts.orders), "dims": None, "selected": False}
    if len(y) < opts.min_select:
        return {"orders": tuple(opts.default_orders), "dims": None, "selected": False,
                "reason": f"{len(y)} observations < min_select={opts.min_select}"}
    from ksbo_mav.select import select_orders

    # C_ree is computed with the base lengthscale the GP will use, so the ranking is about this model.
    top_order = d if opts.max_order is None else max(1, min(d, int(opts.max_order)))
    sel = select_orders(X, y, orders=range(1, top_order + 1), trials=opts.trials, top=min(opts.top, top_order),
                        seed=seed, lengthscales=opts.lengthscale)
    orders = tuple(int(r) for r in sel.orders)[: opts.top]
    out: dict[str, Any] = {
        "orders": orders,
        "dims": None,
        "selected": True,
        "cree": {int(r): float(v) for r, v in sel.mean.items()},
        "top_frequency": {int(r): float(v) for r, v in sel.top_frequency.items()},
    }
    if opts.dims != "all":
        from ksbo_mav.select import select_dimensions

        kept: set[int] = set()
        per_order = {}
        for r in orders:
            ds = select_dimensions(X, y, r, method=opts.dims, seed=seed)
            dims_r = getattr(ds, "dims", ds)
            per_order[int(r)] = [int(i) for i in dims_r]
            kept.update(per_order[int(r)])
        # Every kept order needs at least `order` dimensions.
        if len(kept) >= max(orders):
            out["dims"] = tuple(sorted(kept))
        out["dims_per_order"] = per_order
    return out


def _build(
    problem: Problem, opts: Options, orders: tuple[int, ...], dims: tuple[int, ...] | None, seed: int | None,
    rng: np.random.Generator,
) -> SafeBO:
    d = problem.dim
    orders = tuple(r for r in orders if 1 <= r <= d) or (d,)
    spec = model_spec(opts, orders, dims)
    if dims is not None:
        # Orders above the number of active dimensions do not exist on the subspace.
        spec = spec.with_(orders=tuple(r for r in orders if r <= len(dims)) or (len(dims),))
    model = SafetyModel(spec, d, problem.p_min, seed=seed)
    safety = None
    if opts.safety_kernel == "se" and spec.orders != (d,):
        # A local, product-SE GP must certify safety too: additive kernels keep a high correlation when one
        # dimension changes a lot, which on a task with cliffs certifies unsafe gains (see BENCHMARKS.md).
        sspec = model_spec(opts.update({"lengthscale": opts.safety_lengthscale}), (d,), None)
        safety = SafetyModel(sspec, d, problem.p_min, seed=seed)
    elif opts.safety_kernel not in ("same", "se"):
        raise ValueError(f"unknown safety_kernel {opts.safety_kernel!r}")
    return SafeBO(model, bo_config(opts), active_mask(d, dims, spec.dropped_in_order1), rng, x0=problem.x0,
                  safety_model=safety, n_prior=len(problem.prior_y), budget=problem.budget)


def run_safe_method(problem: Problem, method: str, opts: Options, seed: int | None) -> OptimizeResult:
    """Run ``ksbo``, ``standard`` or ``safeopt`` on ``problem`` (x0 already evaluated).

    ksbo selects its kernel on the data available before BO (prior + x0); with ``select_at = k > 0`` it selects
    again on all data after k BO iterations (for runs without an informative prior) and continues with the new
    kernel, keeping the iteration counter and the prior scales.
    """
    d = problem.dim
    X, y = problem.data()
    info: dict[str, Any] = {"options": opts}
    if method == "ksbo":
        sel = select_kernel(X, y, opts, seed)
        orders, dims = sel["orders"], sel["dims"]
        info["selection"] = sel
    elif method == "standard":
        orders, dims = (1, d) if d > 1 else (1,), None
    elif method == "safeopt":
        orders, dims = (d,), None
    else:
        raise ValueError(method)
    rng = np.random.default_rng(seed)
    bo = _build(problem, opts, orders, dims, seed, rng)
    bo.fit(X, y)
    reselect = method == "ksbo" and opts.select_at > 0 and opts.orders is None
    log = run_safe_bo(problem, bo, max_iters=opts.select_at if reselect else None)
    if reselect and problem.remaining > 0:
        X, y = problem.data()
        sel = select_kernel(X, y, opts, seed)
        info["reselection"] = {"at_iteration": bo.iteration, **sel}
        fixed = opts.update({"signal_std": bo.model.signal_std, "noise_std": bo.model.noise_std})
        old = bo
        bo = _build(problem, fixed, sel["orders"], sel["dims"], seed, rng)
        bo.iteration, bo.fallbacks = old.iteration, old.fallbacks
        bo.fit(X, y)
        log += run_safe_bo(problem, bo)
    info["proposals"] = log
    i, mu, lcb = bo.recommend()
    info["signal_std"] = bo.model.signal_std
    info["noise_std"] = bo.model.noise_std
    return build_result(
        problem, method, i, mu=mu, lcb=lcb, orders=tuple(bo.model.spec.orders), dims=bo.model.spec.active_dims,
        fallbacks=bo.fallbacks, info=info,
    )
