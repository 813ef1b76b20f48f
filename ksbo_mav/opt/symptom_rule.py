"""A rule that reads what the flights show beyond their score: the pitch rate's limit cycle (``chatter_dim``).

Why (issue 13 items AI, AL, AM): along the pitch D gain the score is a plateau — a D gain too high for the loop's
sample rate drives a high-frequency limit cycle that costs little score — with better gains behind it and, further
down, gains whose loop is too weakly damped to recover from a hard start. The flights show the first side (the
``pitch_line`` symptom, :mod:`ksbo_mav.symptoms`) but not the second: the best D gains of the safe climbs sit just
below where the cycle stops (mass +30 %: cycling at 0.25, quiet from 0.2, best 0.21; the runs' crashes at
0.14–0.17, where the same gains fail from 8–73 % of random starts and are safe at 0.2).

So, with ``chatter_dim`` set:

* **step down** — every ``chatter_every``-th BO iteration, while the incumbent's flights cycle, query the lowest
  certified value of that gain on the line through the incumbent, at most ``chatter_step`` down;
* **floor** (``chatter_floor`` > 0; off by default) — once any flight has cycled, no query sets that gain more than
  ``chatter_floor`` below the lowest value a cycling flight had: the optimiser may settle just below the cycle's
  onset but not wander into the weakly damped gains the score cannot see coming. Measured (item AM): with steps of
  0.025 mass +30 % crashed in 1 of 10 seeds with or without a floor of 0.05, and the floor cost on the nominal
  tuning seeds (mean E[P] 0.862 → 0.839, 1 crash), so it stays off.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ksbo_mav.opt import region
from ksbo_mav.opt.lines import axis_line, every

if TYPE_CHECKING:
    from ksbo_mav.opt.safe_bo import Proposal, SafeBO


def _symptom(bo: "SafeBO", i: int) -> float:
    """The rule's symptom of the run's i-th evaluation (``bo.X[bo.n_prior + i]``); NaN if not reported."""
    s = bo.symptoms[i] if i < len(bo.symptoms) else None
    return float(s.get(bo.config.chatter_symptom, np.nan)) if s else float("nan")


def incumbent_symptom(bo: "SafeBO", xb: np.ndarray) -> float | None:
    """Mean symptom over the run's flights at exactly ``xb`` (d,), or None if none reported it."""
    if not bo.symptoms:
        return None
    idx = np.flatnonzero(np.all(bo.X[bo.n_prior :] == xb, axis=1))
    vals = [v for v in (_symptom(bo, int(i)) for i in idx) if np.isfinite(v)]
    return float(np.mean(vals)) if vals else None


def symptom_turn(bo: "SafeBO") -> bool:
    """Does this iteration check for the symptom? Every ``chatter_every``-th BO iteration before exploitation, when
    ``chatter_dim`` is set."""
    return bo.config.chatter_dim >= 0 and every(bo, bo.config.chatter_every)


def symptom_proposal(bo: "SafeBO") -> "Proposal | None":
    """While the incumbent's flights cycle: the lowest certified value of gain ``chatter_dim`` on the line through
    the incumbent, at most ``chatter_step`` down (the score along it may be a plateau that rewards the step only
    past a cliff). None when the incumbent does not cycle or nothing lower is certified."""
    dim = bo.config.chatter_dim
    xb = region.incumbent(bo)
    level = incumbent_symptom(bo, xb)
    if level is None or level <= bo.config.chatter_threshold or not bo.free[dim]:
        return None
    s, P, i0, _, _, lo, _ = axis_line(bo, xb, dim)
    lo = max(lo, int(np.searchsorted(s, -bo.config.chatter_step)))  # at most chatter_step down
    return None if lo >= i0 - 1 else bo.finish_proposal(P[lo], "symptom")


def symptom_floor(bo: "SafeBO") -> float | None:
    """Lowest value (unit cube) gain ``chatter_dim`` may be queried at: ``chatter_floor`` below the lowest value a
    cycling flight of this run had; None while no flight has cycled, or without the rule or the floor."""
    c = bo.config
    if c.chatter_dim < 0 or not c.chatter_floor > 0 or not bo.symptoms:
        return None
    n = min(len(bo.symptoms), len(bo.X) - bo.n_prior)
    cycling = [bo.X[bo.n_prior + i, c.chatter_dim] for i in range(n) if _symptom(bo, i) > c.chatter_threshold]
    return float(min(cycling)) - c.chatter_floor if cycling else None
