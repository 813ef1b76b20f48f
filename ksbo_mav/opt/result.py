"""Result type shared by every optimiser in :mod:`ksbo_mav.opt`."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class OptimizeResult:
    """What :func:`ksbo_mav.optimize` returns.

    Attributes:
        x: (d,) recommended gains (physical units), chosen by the model for GP methods.
        fun: mean observed value at ``x`` (over its evaluations, prior included).
        X: (n, d) every evaluation of ``fun`` in call order (physical units); the prior is not included.
        y: (n,) the observed values of ``X``.
        n_unsafe: number of evaluations with ``y < p_min`` (the paper's count; aborted and crashed trials
            included; prior excluded).
        n_aborted: trials the monitor aborted and the backup recovered (``fun`` returned an aborted Evaluation).
        n_crashed: trials that crashed (the backup did not recover).
        outcomes: (n,) "complete" / "aborted" / "crashed" per evaluation.
        selection: typed kernel selection of the final model (:class:`ksbo_mav.opt.models.selection.KernelSelection`);
            ``info["selection"]`` is its first-selection dict.
        method: optimiser name.
        p_min: the safety threshold used.
        prior_X: (m, d) prior inputs (physical units); (0, d) without prior.
        prior_y: (m,) prior values.
        orders: kernel orders the model used (ksbo: the selected ones, best first); None without a GP.
        dims: dimensions (indices) the kernel is active on; None means all.
        mu: posterior mean at ``x`` (None without a GP).
        lcb: posterior lower confidence bound at ``x`` (None without a GP).
        seconds: (n,) optimiser time spent before each evaluation, excluding ``fun`` itself.
        fallbacks: iterations in which no candidate was certified safe and the best-LCB point was re-evaluated.
        info: method-specific extras (selection tables, configuration).
    """

    x: np.ndarray
    fun: float
    X: np.ndarray
    y: np.ndarray
    n_unsafe: int
    method: str
    p_min: float
    prior_X: np.ndarray
    prior_y: np.ndarray
    orders: tuple[int, ...] | None = None
    dims: tuple[int, ...] | None = None
    mu: float | None = None
    lcb: float | None = None
    seconds: np.ndarray = field(default_factory=lambda: np.zeros(0))
    fallbacks: int = 0
    info: dict[str, Any] = field(default_factory=dict)
    n_aborted: int = 0
    n_crashed: int = 0
    outcomes: tuple[str, ...] = ()
    selection: Any = None  # ksbo_mav.opt.models.selection.KernelSelection of the final kernel (GP methods)

    @property
    def nfev(self) -> int:
        """Number of calls of ``fun`` (equals the budget unless a callback stopped the run)."""
        return int(len(self.y))

    @property
    def best_observed(self) -> float:
        """Largest single observation (optimistic under noise; use :attr:`x` for the recommendation)."""
        return float(np.max(self.y)) if len(self.y) else float("nan")

    def __repr__(self) -> str:  # short: arrays of 200 points are not useful in a REPL
        return (
            f"OptimizeResult(method={self.method!r}, fun={self.fun:.4g}, nfev={self.nfev}, "
            f"n_unsafe={self.n_unsafe}, n_aborted={self.n_aborted}, n_crashed={self.n_crashed}, "
            f"orders={self.orders}, x={np.array2string(self.x, precision=4)})"
        )
