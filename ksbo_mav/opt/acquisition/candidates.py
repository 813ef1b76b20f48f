"""Candidate generation for acquisition maximisation in the unit cube.

In 9-D a global quasi-random set almost never lands in a small safe region (SafeCtrlBO found 4 of 4096 Sobol
points certified safe around a clustered seed), so candidates are mostly *local*: Gaussian clouds at several
scales around certified-safe anchor points, plus a global Sobol set for coverage. The best few are then refined
by a batched (1+λ) evolution strategy that only accepts moves satisfying the caller's constraint (e.g. the safety
LCB). The refiner needs no gradients and evaluates each round as one batch, which keeps GP overhead to a few
``predict`` calls per iteration.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from scipy.stats import qmc


def sobol(n: int, dim: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` scrambled Sobol points in ``[0, 1]^dim``; returns (n, dim)."""
    if n <= 0:
        return np.zeros((0, dim))
    m = int(np.ceil(np.log2(n)))
    pts = qmc.Sobol(d=dim, scramble=True, seed=rng).random_base2(m)
    return pts[:n]


def local_gaussian(
    centers: np.ndarray,
    n: int,
    scales: tuple[float, ...],
    rng: np.random.Generator,
    free: np.ndarray | None = None,
    weights: np.ndarray | None = None,
    lo: np.ndarray | float = 0.0,
    hi: np.ndarray | float = 1.0,
) -> np.ndarray:
    """Gaussian samples around ``centers`` (k, d), clipped to the box ``lo``..``hi`` (default the cube); returns
    (n, d).

    Each sample picks a centre (by ``weights``, default uniform) and a scale from ``scales`` uniformly; only the
    dimensions marked in ``free`` (d,) bool are perturbed (the rest stay at the centre's value). Half of the
    samples move along a random subset of about three dimensions, because in 9-D an isotropic step of a useful
    length almost always leaves a thin safe region in some direction.
    """
    centers = np.atleast_2d(centers)
    k, d = centers.shape
    if n <= 0 or k == 0:
        return np.zeros((0, d))
    free = np.ones(d, dtype=bool) if free is None else np.asarray(free, dtype=bool)
    p = None if weights is None else np.asarray(weights, float) / np.sum(weights)
    idx = rng.choice(k, size=n, p=p)
    sc = rng.choice(np.asarray(scales, dtype=float), size=n)
    step = rng.standard_normal((n, d)) * sc[:, None]
    sparse = rng.random(n) < 0.5
    if sparse.any():
        n_free = max(int(free.sum()), 1)
        keep = rng.random((int(sparse.sum()), d)) < min(1.0, 3.0 / n_free)
        step[sparse] *= keep
    step[:, ~free] = 0.0
    return np.clip(centers[idx] + step, lo, hi)


def refine(
    evaluate: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    starts: np.ndarray,
    rng: np.random.Generator,
    rounds: int = 4,
    samples: int = 32,
    scale: float = 0.05,
    free: np.ndarray | None = None,
    lo: np.ndarray | float = 0.0,
    hi: np.ndarray | float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Batched constrained local search: maximise a score from each start, never leaving the feasible set.

    Args:
        evaluate: ``evaluate(X (m, d)) -> (score (m,), feasible (m,) bool)``.
        starts: (k, d) feasible start points.
        rounds: refinement rounds; the step scale halves each round.
        samples: perturbations per start and round.
        scale: initial step standard deviation (unit cube).
        free: (d,) bool dimensions that may move.
        lo, hi: the box the moves stay in (default the cube).

    Returns:
        (k, d) refined points and their (k,) scores; a start is returned unchanged if nothing better and feasible
        was found, so infeasible starts stay infeasible (callers pass feasible ones).
    """
    X = np.atleast_2d(np.asarray(starts, dtype=float)).copy()
    k, d = X.shape
    score, _ = evaluate(X)
    score = np.asarray(score, dtype=float).copy()
    free = np.ones(d, dtype=bool) if free is None else np.asarray(free, dtype=bool)
    if k == 0 or rounds <= 0 or not free.any():
        return X, score
    for r in range(rounds):
        s = scale * 0.5**r
        step = rng.standard_normal((k, samples, d)) * s
        step[:, :, ~free] = 0.0
        trial = np.clip(X[:, None, :] + step, lo, hi).reshape(k * samples, d)
        t_score, t_ok = evaluate(trial)
        t_score = np.where(np.asarray(t_ok, bool), t_score, -np.inf).reshape(k, samples)
        j = np.argmax(t_score, axis=1)
        best = t_score[np.arange(k), j]
        better = best > score
        X[better] = trial.reshape(k, samples, d)[np.arange(k), j][better]
        score[better] = best[better]
    return X, score
