"""Public entry point: ``ksbo_mav.optimize(fun, x0, bounds, *, budget, method="ksbo", ...)``."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Callable

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.opt import METHODS, run_problem
from ksbo_mav.opt.options import options_for
from ksbo_mav.opt.problem import Problem
from ksbo_mav.opt.result import OptimizeResult


def _as_matrix(name: str, a: Any, shape: tuple[int | None, ...]) -> np.ndarray:
    try:
        arr = np.asarray(a, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be numeric: {exc}") from None
    if arr.ndim != len(shape) or any(s is not None and s != n for s, n in zip(shape, arr.shape)):
        want = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
        raise InputError(f"{name} must have shape {want}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name} contains NaN or infinite values")
    return arr


def optimize(
    fun: Callable[[np.ndarray], float],
    x0: Any,
    bounds: Any,
    *,
    budget: int,
    method: str = "ksbo",
    prior: tuple[Any, Any] | None = None,
    seed: int | None = None,
    p_min: float = 0.0,
    callback: Callable[[int, np.ndarray, float], bool | None] | None = None,
    check_x0: bool = True,
    early_stop: Mapping[str, Any] | None = None,
    limits: Any = None,
    on_grow: Callable[[dict[str, Any]], None] | None = None,
    **options: Any,
) -> OptimizeResult:
    """Maximise ``fun`` without (knowingly) evaluating it below ``p_min``, starting from the safe ``x0``.

    Args:
        fun: ``fun(x: ndarray (d,)) -> float``; larger is better, values below ``p_min`` are unsafe. It may also
            return :class:`ksbo_mav.opt.evaluation.Evaluation` ``(value, outcome)`` to report a trial the monitor
            aborted (censored: the optimiser learns "aborts here", not a value) or one that crashed.
        x0: (d,) known-safe start, inside ``bounds``. It is the first evaluation (counted in ``budget``).
        bounds: (d, 2) lower/upper bounds (lower < upper); the methods work in the unit cube of this box.
        budget: number of calls of ``fun`` (≥ 1), x0's included; the prior is not counted.
        method: one of ``ksbo`` (kernel-selected safe BO), ``ksbo-adaptive`` (ksbo with a learned safety scale,
            trust region, abort cap ``max_aborts``, re-flown recommendation and order re-selection),
            ``standard`` (safe BO, orders 1 + d), ``safeopt``
            (SafeOpt rule, SE-ARD GP), ``linebo`` (safe LineBO), ``ucb``, ``ei`` (unconstrained BO), ``random``.
        prior: optional ``(X (m, d), y (m,))`` evaluations already made (physical units); used by the model and by
            ksbo's kernel selection, never re-evaluated.
        seed: random seed (candidates, selection); a fixed seed and a deterministic ``fun`` reproduce the run.
        p_min: safety threshold.
        callback: ``callback(i, x, y)`` after every call of ``fun``; return True to stop early.
        early_stop: None spends the budget; a table {min_evals, patience, ratio, noise} (keys left out keep their
            defaults) ends a safe method's search before it once what the next proposal can gain stays below
            ``ratio`` × the re-flight noise (:mod:`ksbo_mav.opt.methods.stopping`); ``result.info["stop"]`` says
            where and why. The budget stays the ceiling.
        limits: None, or (d, 2) lower/upper limits containing ``bounds``: ``bounds`` is then the first search box
            of a safe method, which grows towards ``limits`` where its incumbent sits on an edge
            (:mod:`ksbo_mav.opt.acquisition.growing_box`); the prior may lie anywhere within ``limits``.
            ``on_grow(growth)`` hears each edge as it moves (trial, dim, side, old, new; also in
            ``result.info["box"]``).
        check_x0: raise :class:`ksbo_mav.errors.UnsafeStartError` (an :class:`InputError`) if ``fun(x0) < p_min``
            or x0's trial aborted or crashed (the run cannot be safe from there).
        **options: method settings, see :class:`ksbo_mav.opt.options.Options` (e.g. ``beta=3.0``,
            ``orders=(2, 3)``, ``lengthscale=0.2``); unknown names raise :class:`InputError`.

    Returns:
        :class:`ksbo_mav.opt.OptimizeResult` with ``x`` (recommended point), ``fun`` (its mean observed value),
        ``X``/``y`` (every evaluation in order), ``n_unsafe`` and, for ksbo, ``orders``/``dims``.

    Raises:
        InputError: bad shapes, x0 outside bounds, budget < 1, unknown method or option.
        UnsafeStartError: unsafe x0 (subclass of InputError).
        ObjectiveError: ``fun`` returned NaN, None, an array or a non-number (names the evaluation); an exception
            raised by ``fun`` propagates unchanged with a note naming the evaluation.
    """
    if method not in METHODS:
        raise InputError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    if not callable(fun):
        raise InputError("fun must be callable")
    if isinstance(budget, bool) or not isinstance(budget, (int, np.integer)) or budget < 1:
        raise InputError(f"budget must be an integer ≥ 1, got {budget!r}")
    if not np.isfinite(p_min):
        raise InputError("p_min must be finite")
    b = _as_matrix("bounds", bounds, (None, 2))
    d = b.shape[0]
    if d < 1:
        raise InputError("bounds must have at least one row")
    if np.any(b[:, 0] >= b[:, 1]):
        raise InputError("bounds must satisfy lower < upper in every row")
    x = _as_matrix("x0", x0, (d,))
    if np.any(x < b[:, 0]) or np.any(x > b[:, 1]):
        raise InputError("x0 lies outside bounds")
    opts = options_for(method, options)
    stop = None if early_stop is None else dict(early_stop)
    if stop is not None:
        from ksbo_mav.opt.methods.stopping import rule_from

        rule_from(stop)  # InputError naming a bad key or value, before anything is evaluated

    lower, upper = b[:, 0], b[:, 1]
    lim = b if limits is None else _as_matrix("limits", limits, (d, 2))
    if np.any(lim[:, 0] > lower) or np.any(lim[:, 1] < upper):
        raise InputError("limits must contain bounds")
    pX, py = np.zeros((0, d)), np.zeros(0)
    if prior is not None:
        try:
            pX_raw, py_raw = prior
        except (TypeError, ValueError):
            raise InputError("prior must be a pair (X, y)") from None
        pX = _as_matrix("prior X", pX_raw, (None, d))
        py = _as_matrix("prior y", py_raw, (pX.shape[0],))
        if np.any(pX < lim[:, 0]) or np.any(pX > lim[:, 1]):
            raise InputError("prior X has points outside " + ("bounds" if limits is None else "limits"))
        pX = (pX - lower) / (upper - lower)

    problem = Problem(
        fun=fun, lower=lower, upper=upper, x0=(x - lower) / (upper - lower), budget=int(budget),
        p_min=float(p_min), prior_X=pX, prior_y=py, callback=callback, early_stop=stop,
        limit_lo=(lim[:, 0] - lower) / (upper - lower), limit_hi=(lim[:, 1] - lower) / (upper - lower),
        on_grow=on_grow,
    )
    return run_problem(problem, method, opts, seed, check_x0=check_x0)
