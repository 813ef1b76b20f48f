"""Confirmation flights: the recommended gains flown again before anyone leaves them on the vehicle."""

from __future__ import annotations

import numpy as np

from ksbo_mav.campaign.journal import JournalEntry
from ksbo_mav.campaign.trials import TrialLoop


def fly_confirmations(trials: TrialLoop, best: np.ndarray, n: int) -> list[float]:
    """P of ``n`` confirmation flights of ``best`` (d,): the journalled ones (a resume), then new ones."""
    confirms = [e.P for e in trials.journal.of("confirm")]
    for _ in range(len(confirms), n):
        confirms.append(trials.fly(best, "confirm").P)
    return confirms


def confirm_failures(confirms: list[JournalEntry]) -> list[str]:
    """Why the recommended gains should not be left on the vehicle: one line per confirmation flight that was
    aborted, crashed or scored P < 0 (empty: every confirmation flight completed safely, or there was none)."""
    return [f"confirmation trial {e.trial}: {e.outcome.text}" if e.outcome != "ok" else
            f"confirmation trial {e.trial}: P = {e.P:.3f} < 0" for e in confirms if e.outcome != "ok" or e.P < 0]
