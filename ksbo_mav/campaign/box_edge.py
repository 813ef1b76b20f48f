"""Where the recommendation touches the edge of the search box, said in plain words.

A safe-BO campaign only searches its box: the profile's gain limits intersected with the trust region around the
baseline (:func:`ksbo_mav.mav.gains.trust_region`) at first, grown where the best flights reached an edge. When the
recommended value of a gain sits on an edge of that box, the best gains may lie past it, and the user should know:
the campaign's improvement was capped by the box, not by the vehicle. This module is pure (numpy only) and
unit-agnostic: give values, bounds and limits in one unit (the vehicle's, to print what the vehicle shows).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

#: Closeness to an edge, as a fraction of the search box's width for that gain.
TOL = 0.02


@dataclass(frozen=True)
class EdgeHit:
    """One gain of the recommendation on one edge of the search box.

    Attributes:
        name: the gain's (vehicle) name; value: its recommended value.
        side: ``"lower"`` or ``"upper"``; bound: the search box's edge on that side.
        limit: the profile's own limit on that side (None when not given).
        near_best: of the ``n_near`` flown points near the top, how many sit on the same edge.
    """

    name: str
    value: float
    side: str
    bound: float
    limit: float | None = None
    near_best: int = 0
    n_near: int = 0

    @property
    def at_limit(self) -> bool:
        """The box's edge is the profile's limit (not the trust region around the baseline)."""
        return self.limit is not None and bool(np.isclose(self.bound, self.limit, rtol=1e-6, atol=1e-9))

    def message(self) -> str:
        """One plain line for the console and the report page."""
        head = f"{self.name} = {self.value:.4g} is at the {self.side} bound {self.bound:.4g} of the search box"
        support = (f"; {self.near_best} of the {self.n_near} best flights sit on this edge too"
                   if self.n_near and self.near_best else "")
        if self.at_limit:
            return (f"{head}, which is the profile's {self.side} limit{support}: the search cannot go past it; if "
                    f"the gain should go further, check the autopilot's documented range and change the profile's "
                    f"[[gains]] {'min' if self.side == 'lower' else 'max'}")
        beyond = f"; the profile allows {self.limit:.4g}" if self.limit is not None else ""
        return (f"{head} (it grows from the baseline's trust region{beyond}){support}: the improvement may continue "
                "past it; accept these gains and tune again from them (the first box is centred on the vehicle's "
                "gains), or fly a longer campaign (--budget)")


def edge_hits(x: Sequence[float], bounds: np.ndarray, names: Sequence[str], *, tol: float = TOL,
              limits: np.ndarray | None = None, near_best: np.ndarray | None = None) -> list[EdgeHit]:
    """The gains of ``x`` (d,) within ``tol`` of the box's width of an edge of ``bounds`` (d, 2).

    ``limits`` (d, 2): the profile's own gain limits, to tell the trust region's edge from the profile's.
    ``near_best`` (m, d): points known to be good and safe near the top (flown, or certified by the posterior);
    each hit counts how many of them sit on the same edge. A gain whose box has no width is never a hit, nor is one
    at a profile's lower limit of 0 (a gain switched off: no gain lies below it).
    Hits are in gain order, lower edge before upper.
    """
    x = np.asarray(x, dtype=float).reshape(-1)
    b = np.asarray(bounds, dtype=float).reshape(-1, 2)
    if len(x) != len(b) or len(names) != len(b):
        raise ValueError(f"x has {len(x)} gains, bounds {len(b)}, names {len(names)}")
    near = np.asarray(near_best, dtype=float).reshape(-1, len(b)) if near_best is not None else np.zeros((0, len(b)))
    lim = np.asarray(limits, dtype=float).reshape(-1, 2) if limits is not None else None
    hits = []
    for i, name in enumerate(names):
        lo, hi = b[i]
        width = hi - lo
        if not width > 0:
            continue
        margin = tol * width
        for side, edge, close in (("lower", lo, lambda v: v <= lo + margin), ("upper", hi, lambda v: v >= hi - margin)):
            if not close(x[i]):
                continue
            hit = EdgeHit(name=str(name), value=float(x[i]), side=side, bound=float(edge),
                          limit=None if lim is None else float(lim[i, 0 if side == "lower" else 1]),
                          near_best=int(sum(close(v) for v in near[:, i])), n_near=len(near))
            if not (hit.at_limit and side == "lower" and edge == 0):  # a gain cannot go below 0: no cap there
                hits.append(hit)
    return hits


def edge_lines(hits: Sequence[EdgeHit]) -> list[str]:
    """The console / report lines: one per hit, or nothing when the recommendation is inside the box."""
    return [h.message() for h in hits]
