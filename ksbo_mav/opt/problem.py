"""The optimisation problem as every method sees it: unit cube, budgeted evaluator, timing.

Methods work in the unit cube ``[0, 1]^d``; :class:`Problem` maps to physical units, counts calls of the user's
function, enforces the budget and measures optimiser overhead (wall time between the end of one call of ``fun``
and the start of the next, i.e. everything except the objective itself).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from ksbo_mav.opt.evaluation import Evaluation, Outcome, as_evaluation
from ksbo_mav.opt.result import OptimizeResult


class BudgetExhausted(RuntimeError):
    """A method tried to call ``fun`` more often than the budget allows (a bug in the method)."""


@dataclass
class Problem:
    """Budgeted objective in the unit cube.

    Attributes:
        fun: physical-unit objective ``fun(x: (d,)) -> float | Evaluation`` (``opt.evaluation``); larger is better,
            ``< p_min`` unsafe; aborted/crashed trials are censored.
        lower, upper: (d,) box bounds (physical).
        x0: (d,) known-safe start in the unit cube.
        budget: maximum number of calls of ``fun``.
        p_min: safety threshold.
        prior_X: (m, d) prior inputs in the unit cube; prior_y: (m,) their values.
        callback: ``callback(i, x, y) -> bool | None`` after each call (physical x); truthy stops the run
            (sets ``stopped``; ``remaining`` is then 0).
        early_stop: the stopping rule's settings (opt.methods.stopping), or None: spend the budget.
        limit_lo, limit_hi: (d,) how far a growing search box may go (unit cube: ≤ 0 and ≥ 1;
            opt.acquisition.growing_box); None: the box is the cube.
        on_grow: ``on_grow(growth)`` as the box grows, one call per edge moved (``growth`` as in
            ``result.info["box"]["growth"]``: trial, dim, side, old, new in physical units).
    """

    fun: Callable[[np.ndarray], float]
    lower: np.ndarray
    upper: np.ndarray
    x0: np.ndarray
    budget: int
    p_min: float = 0.0
    prior_X: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    prior_y: np.ndarray = field(default_factory=lambda: np.zeros(0))
    callback: Callable[[int, np.ndarray, float], bool | None] | None = None
    early_stop: dict[str, Any] | None = None
    limit_lo: np.ndarray | None = None
    limit_hi: np.ndarray | None = None
    on_grow: Callable[[dict[str, Any]], None] | None = None
    X: list[np.ndarray] = field(default_factory=list, init=False)
    y: list[float] = field(default_factory=list, init=False)
    outcomes: list[Outcome] = field(default_factory=list, init=False)
    seconds: list[float] = field(default_factory=list, init=False)
    stopped: bool = field(default=False, init=False)
    _t_last: float = field(default=0.0, init=False)

    def __post_init__(self) -> None:
        self.lower = np.asarray(self.lower, dtype=float)
        self.upper = np.asarray(self.upper, dtype=float)
        self.x0 = np.asarray(self.x0, dtype=float)
        if self.prior_X.size == 0:
            self.prior_X = np.zeros((0, self.dim))
        self.limit_lo = np.zeros(self.dim) if self.limit_lo is None else np.asarray(self.limit_lo, dtype=float)
        self.limit_hi = np.ones(self.dim) if self.limit_hi is None else np.asarray(self.limit_hi, dtype=float)
        self._t_last = time.perf_counter()

    @property
    def dim(self) -> int:
        return int(self.lower.shape[0])

    @property
    def can_grow(self) -> bool:
        """Whether the search box may grow past the unit cube (limits wider than the caller's bounds)."""
        return bool(np.any(self.limit_lo < 0.0) or np.any(self.limit_hi > 1.0))

    @property
    def n_evals(self) -> int:
        return len(self.y)

    @property
    def remaining(self) -> int:
        """Evaluations left; 0 once the callback asked to stop, so every method's loop ends there."""
        return 0 if self.stopped else self.budget - len(self.y)

    def to_physical(self, u: np.ndarray) -> np.ndarray:
        """(…, d) unit-cube points → physical units."""
        return self.lower + np.asarray(u, dtype=float) * (self.upper - self.lower)

    def to_physical_1(self, i: int, u: float) -> float:
        """Unit-cube coordinate ``u`` of dimension ``i`` → physical units."""
        return float(self.lower[i] + u * (self.upper[i] - self.lower[i]))

    def growth_record(self, g: Any) -> dict[str, Any]:
        """One :class:`~ksbo_mav.opt.acquisition.growing_box.Growth` in physical units."""
        return {"trial": g.trial, "dim": g.dim, "side": g.side, "old": self.to_physical_1(g.dim, g.old),
                "new": self.to_physical_1(g.dim, g.new)}

    def to_unit(self, x: np.ndarray) -> np.ndarray:
        """(…, d) physical points → unit cube."""
        return (np.asarray(x, dtype=float) - self.lower) / (self.upper - self.lower)

    def evaluate(self, u: np.ndarray) -> float:
        """Call ``fun`` once at unit-cube point ``u`` (d,), record it and return its value.

        For methods that need a number for every trial: an aborted or crashed trial returns its reported value
        if below ``p_min``, else ``p_min − 1`` (:meth:`evaluate_full` gives the censored view).
        """
        return self.evaluate_full(u)[1]

    @property
    def can_stress(self) -> bool:
        """Whether ``fun`` offers a flight from its hardest start (``fun.stress(x)``, same return as ``fun``)."""
        return callable(getattr(self.fun, "stress", None))

    def evaluate_full(self, u: np.ndarray, stress: bool = False) -> tuple[Evaluation, float]:
        """Call ``fun`` once at ``u`` (d,) (``fun.stress`` with ``stress`` where :attr:`can_stress`); returns the
        :class:`Evaluation` and the recorded value (see above)."""
        if self.budget - len(self.y) <= 0:
            raise BudgetExhausted(f"budget of {self.budget} evaluations already used")
        start = time.perf_counter()
        self.seconds.append(start - self._t_last)
        u = np.clip(np.asarray(u, dtype=float).reshape(self.dim), self.limit_lo, self.limit_hi)
        x = self.to_physical(u)
        i = len(self.y)
        try:
            raw = self.fun.stress(x.copy()) if stress and self.can_stress else self.fun(x.copy())
        except Exception as exc:
            exc.add_note(f"raised by fun at evaluation {i} (x = {np.array2string(x, precision=4)})")
            raise
        ev = as_evaluation(raw, i, x)
        value = ev.value
        if ev.censored:
            value = self.p_min - 1.0 if value is None or value >= self.p_min else value
        self.X.append(u)
        self.y.append(float(value))
        self.outcomes.append(ev.outcome)
        if self.callback is not None and self.callback(i, x, float(value)):
            self.stopped = True
        self._t_last = time.perf_counter()
        return ev, float(value)

    def stop(self) -> None:
        """End the run (e.g. the abort budget is spent): ``remaining`` becomes 0."""
        self.stopped = True

    def count(self, outcome: Outcome) -> int:
        """Evaluations that ended with ``outcome``."""
        return sum(o is outcome for o in self.outcomes)

    def data(self) -> tuple[np.ndarray, np.ndarray]:
        """All observations so far, prior first: (n, d) unit-cube inputs and (n,) values."""
        X = np.vstack([self.prior_X, np.asarray(self.X).reshape(-1, self.dim)])
        y = np.concatenate([self.prior_y, np.asarray(self.y, dtype=float)])
        return X, y


def build_result(
    problem: Problem,
    method: str,
    index: int,
    *,
    mu: float | None = None,
    lcb: float | None = None,
    orders: tuple[int, ...] | None = None,
    dims: tuple[int, ...] | None = None,
    fallbacks: int = 0,
    info: dict | None = None,
) -> OptimizeResult:
    """Assemble the :class:`OptimizeResult` for the recommendation ``problem.data()[0][index]``.

    ``fun`` is the mean of every observation at exactly that point (prior included), since safe BO may
    re-evaluate a point and a single noisy value would flatter it.
    """

    X, y = problem.data()
    u = X[index]
    same = np.all(np.abs(X - u) <= 1e-12, axis=1)
    y_eval = np.asarray(problem.y, dtype=float)
    return OptimizeResult(
        x=problem.to_physical(u),
        fun=float(np.mean(y[same])),
        X=problem.to_physical(np.asarray(problem.X).reshape(-1, problem.dim)),
        y=y_eval,
        n_unsafe=int(np.sum(y_eval < problem.p_min)),
        n_aborted=problem.count(Outcome.ABORTED),
        n_crashed=problem.count(Outcome.CRASHED),
        outcomes=tuple(o.value for o in problem.outcomes),
        method=method,
        p_min=problem.p_min,
        prior_X=problem.to_physical(problem.prior_X),
        prior_y=np.asarray(problem.prior_y, dtype=float).copy(),
        orders=orders,
        dims=dims,
        mu=mu,
        lcb=lcb,
        seconds=np.asarray(problem.seconds, dtype=float),
        fallbacks=fallbacks,
        info=info or {},
    )
