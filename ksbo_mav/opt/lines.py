"""One-dimensional subspaces of the unit cube: the lines safe LineBO searches (opt.linebo) and the coordinate
lines :class:`ksbo_mav.opt.safe_bo.SafeBO` interleaves with its own rule (``line_every``).

Why coordinate lines in SafeBO: on plants whose score is a plateau with a cliff along one gain (issue 13 item AI:
pitch inertia ×0.5, where E[P] jumps 0.3 → 0.9 once the pitch D gain falls below ~0.1 of its range and nothing
on the way rewards the move), a 9-D acquisition follows the steepest gain and never walks that far along the
flat one. A line along each gain in turn, through the incumbent, pushes the certified set along every axis, as
an engineer tuning one gain at a time would (CoordinateLineBO, Kirschner et al. 2019).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ksbo_mav.opt import region

if TYPE_CHECKING:
    from ksbo_mav.opt.safe_bo import Proposal, SafeBO

#: Grid points per coordinate line (a unit-cube axis: steps of 1/400).
LINE_POINTS = 401


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


def every(bo: "SafeBO", k: int) -> bool:
    """Is this the turn of a rule that acts every ``k``-th BO iteration (k > 0) before exploitation?"""
    from ksbo_mav.opt import phases

    return k > 0 and bo.iteration > 0 and bo.iteration % k == 0 and phases.exploring(bo)


def axis_line(bo: "SafeBO", xb: np.ndarray, axis: int) -> tuple[np.ndarray, ...]:
    """The line through ``xb`` (d,) along gain ``axis`` on :data:`LINE_POINTS` points: offsets s (n,), points
    (n, d), the index i0 of ``xb``, the UCB and std (n,), and the certified interval [lo, hi] ∋ i0."""
    direction = np.zeros(xb.size)
    direction[axis] = 1.0
    s, P = line_grid(xb, direction, LINE_POINTS)
    i0 = int(np.argmin(np.abs(s)))
    _, sd, lcb, ucb = bo.bounds(P)
    lo, hi = safe_interval(bo.feasible(P, lcb), i0)
    return s, P, i0, ucb, sd, lo, hi


def line_turn(bo: "SafeBO") -> bool:
    """Does this iteration fly a coordinate line? Every ``line_every``-th BO iteration before exploitation."""
    return every(bo, bo.config.line_every)


def coordinate_proposal(bo: "SafeBO") -> "Proposal | None":
    """The next coordinate line's query through the incumbent, or None when the line offers nothing certified
    beyond the incumbent (the caller then proposes as usual). The axes are taken in turn over the free ones."""
    axes = np.flatnonzero(bo.free)
    if axes.size == 0:
        return None
    axis = int(axes[bo.n_lines % axes.size])
    bo.n_lines += 1
    _, P, i0, ucb, sd, lo, hi = axis_line(bo, region.incumbent(bo), axis)
    if lo == hi:
        return None
    i = line_query(ucb, sd, lo, hi, i0)
    return None if i == i0 else bo.finish_proposal(P[i], "line")
