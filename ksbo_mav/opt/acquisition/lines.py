"""LineBO's proposer on one line (Kirschner et al., ICML 2019): the grid along a line through the unit cube, the
certified interval on it around the current best point, and the point of that interval to query.

The safe interval is the contiguous run of certified-safe grid points containing the best point x_b; the query is
the UCB maximiser on it unless one of the interval's ends (an expander) has a wider confidence interval than that
maximiser. The method that draws the lines and flies the queries is :mod:`ksbo_mav.opt.methods.linebo`.
"""

from __future__ import annotations

import numpy as np


def line_grid(x: np.ndarray, direction: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Points of the segment {x + s·direction} ∩ [0,1]^d on an n-point grid; returns s (n,), points (n, d)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = np.where(direction != 0, (0.0 - x) / direction, -np.inf)
        t2 = np.where(direction != 0, (1.0 - x) / direction, np.inf)
    lo = np.max(np.where(direction != 0, np.minimum(t1, t2), -np.inf))
    hi = np.min(np.where(direction != 0, np.maximum(t1, t2), np.inf))
    s = np.linspace(lo, hi, n)
    s = np.unique(np.append(s, 0.0))  # x itself is on the grid
    return s, np.clip(x[None, :] + s[:, None] * direction[None, :], 0.0, 1.0)


def safe_interval(safe: np.ndarray, i0: int) -> tuple[int, int]:
    """Inclusive index range of the run of True in ``safe`` (n,) containing ``i0``; (i0, i0) if ``safe[i0]`` is
    False."""
    if not safe[i0]:
        return i0, i0
    lo = i0
    while lo > 0 and safe[lo - 1]:
        lo -= 1
    hi = i0
    while hi < len(safe) - 1 and safe[hi + 1]:
        hi += 1
    return lo, hi


def line_query(ucb: np.ndarray, sd: np.ndarray, lo: int, hi: int, i0: int) -> int:
    """Grid index to query on the certified interval [lo, hi] ∋ i0 (LineBO's rule): the UCB maximiser, unless an
    end of the interval (an expander) has a wider confidence interval than it."""
    idx = np.arange(lo, hi + 1)
    ia = int(idx[int(np.argmax(ucb[idx]))])
    ends = [i for i in (lo, hi) if i != i0]
    ie = max(ends, key=lambda i: sd[i], default=None)
    return ie if ie is not None and sd[ie] > sd[ia] else ia
