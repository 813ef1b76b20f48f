"""Journal replay as an objective: a resumed campaign re-runs the optimiser with the same seed and answers its
calls from the journal instead of flying them.

The optimiser is deterministic (same seed, same data, BLAS pinned to one thread), so it proposes the journalled
trials again, in order, and only new trials are flown. Should a proposal ever differ (the optimiser code or a
library changed between the runs), replay stops there: from then on every proposal is flown, and the journalled
trials not replayed stay on record (reported as ``unused``) — none is flown twice, nothing is thrown through the
optimiser.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ksbo_mav.campaign.journal import JournalEntry
from ksbo_mav.opt.evaluation import Evaluation


def evaluation(e: JournalEntry) -> Evaluation:
    """What the optimiser was told for a journalled trial."""
    return Evaluation(e.scored, e.outcome.evaluation)


class JournalReplay:
    """``fun`` for :func:`ksbo_mav.optimize`: the first ``len(done)`` calls from ``done``, the rest from ``fly``.

    With ``fly_stress`` (missions with moving starts) it also has ``stress(x)``, a flight from the stress start for
    the optimiser's ``refly_stress`` screen; a journalled flight replays only the same kind of call. Without it
    there is no ``stress`` and the optimiser re-flies as usual."""

    def __init__(self, done: list[JournalEntry], fly: Callable[[np.ndarray], Evaluation],
                 log: Callable[[str], None] = lambda s: None,
                 fly_stress: Callable[[np.ndarray], Evaluation] | None = None) -> None:
        self.done, self.fly, self.log = done, fly, log
        self.fly_stress = fly_stress
        self.calls = 0
        self.replayed = 0
        self.diverged_at: int | None = None
        if fly_stress is not None:
            self.stress = lambda x: self._answer(x, stress=True)

    def __call__(self, x: np.ndarray) -> Evaluation:
        return self._answer(x, stress=False)

    def _answer(self, x: np.ndarray, stress: bool) -> Evaluation:
        i, self.calls = self.calls, self.calls + 1
        if self.diverged_at is None and i < len(self.done):
            e = self.done[i]
            if np.allclose(x, e.x, rtol=1e-9, atol=1e-12) and e.stress == stress:
                self.replayed += 1
                return evaluation(e)
            self.diverged_at = i
            self.log(f"resume: the optimiser's proposal {i} differs from the journal (code or settings changed?): "
                     f"{len(self.done) - i} journalled trial(s) stay on record unused; flying new proposals")
        return self.fly_stress(x) if stress and self.fly_stress is not None else self.fly(x)

    @property
    def unused(self) -> list[JournalEntry]:
        return [] if self.diverged_at is None else self.done[self.diverged_at:]
