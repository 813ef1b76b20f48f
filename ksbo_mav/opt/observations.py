"""The observation store of the safe optimiser: every trial so far, prior first, with how it ended.

A trial is a point of the unit cube, its score and its outcome. Aborted and crashed trials keep a score below
``p_min`` for the record; whether the GPs see it is :attr:`Observations.gp_mask` (censored: they do not).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ksbo_mav.opt.evaluation import Outcome


@dataclass
class Observations:
    """Points ``X`` (n, d), scores ``y`` (n,), and (n,) bool masks ``complete`` and ``crashed``.

    Attributes:
        dim: d. p_min: the safety threshold (a score below it is unsafe).
        n_prior: leading rows that are prior data (not evaluated by this run).
        censor: aborted and crashed trials are kept out of the GPs' data (:attr:`gp_mask`).
    """

    dim: int
    p_min: float = 0.0
    n_prior: int = 0
    censor: bool = False
    X: np.ndarray = field(init=False)
    y: np.ndarray = field(init=False)
    complete: np.ndarray = field(init=False)
    crashed: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.reset(np.zeros((0, self.dim)), np.zeros(0))

    def reset(self, X: np.ndarray, y: np.ndarray, complete: np.ndarray | None = None,
              crashed: np.ndarray | None = None) -> None:
        """Replace the data: X (n, d), y (n,), optional (n,) bool outcome masks (default: all completed)."""
        self.X = np.asarray(X, dtype=float).reshape(-1, self.dim)
        self.y = np.asarray(y, dtype=float).reshape(-1)
        n = self.y.size
        self.complete = np.ones(n, dtype=bool) if complete is None else np.asarray(complete, dtype=bool)
        self.crashed = np.zeros(n, dtype=bool) if crashed is None else np.asarray(crashed, dtype=bool)

    def add(self, x: np.ndarray, y: float, outcome: Outcome) -> None:
        """Append one trial: x (d,), its score and outcome."""
        self.X = np.vstack([self.X, np.asarray(x, float).reshape(1, -1)])
        self.y = np.append(self.y, float(y))
        self.complete = np.append(self.complete, outcome is Outcome.COMPLETE)
        self.crashed = np.append(self.crashed, outcome is Outcome.CRASHED)

    @property
    def n(self) -> int:
        return int(self.y.size)

    @property
    def gp_mask(self) -> np.ndarray:
        """(n,) bool: trials the GPs are trained on — completed ones when aborts are censored, else all (an aborted
        trial then enters with its recorded value, the behaviour of the paper's method)."""
        return self.complete if self.censor else np.ones_like(self.complete)

    @property
    def aborts(self) -> int:
        """Trials of this run that aborted or crashed (prior excluded)."""
        return int(np.sum(~self.complete[self.n_prior :]))

    @property
    def any_failed(self) -> bool:
        """Whether any trial aborted or crashed."""
        return not bool(self.complete.all())

    def gp_data(self) -> tuple[np.ndarray, np.ndarray]:
        """The GPs' training data: (k, d) points and (k,) scores (:attr:`gp_mask`)."""
        m = self.gp_mask
        return self.X[m], self.y[m]

    def bad(self) -> np.ndarray:
        """(k, d) trials that were unsafe (score < p_min) or did not complete, in the order flown."""
        return self.X[(self.y < self.p_min) | ~self.complete]

    def at(self, x: np.ndarray) -> np.ndarray:
        """(n,) bool: trials at exactly the point x (d,)."""
        return np.all(self.X == np.asarray(x, float).reshape(1, -1), axis=1)

    def safe_complete(self) -> np.ndarray:
        """(n,) bool: completed trials that scored at least p_min."""
        return self.complete & (self.y >= self.p_min)
