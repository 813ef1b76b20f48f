"""Is it the gains or the vehicle? Baseline re-flights at a cadence, and a test on them.

Every :attr:`DriftWatch.every` optimiser trials the campaign flies the baseline gains again (journal kind
``baseline``: never given to the optimiser). The first baseline flight is the reference of every score, so the
re-flights say whether the vehicle still answers the same gains the same way. The test compares the newest
re-flight with that first flight: the lap-2 RMS more than :attr:`DriftWatch.rms_ratio` times the first (the 3-D
figure-8s; re-flights of the same gains on ArduCopter SITL spread by about 5 %), or, where the score has no RMS
(the planar task), P lower by more than :attr:`DriftWatch.p_drop`. When it fires, the vehicle changed, not the
gains: the campaign stops in a safe state (baseline restored, landed, report written) and says so with the
numbers, to be resumed after a check of the vehicle (battery, propellers, payload, wind).
"""

from __future__ import annotations

from dataclasses import dataclass

from ksbo_mav.campaign.journal import Journal
from ksbo_mav.errors import CampaignPaused


@dataclass
class DriftWatch:
    every: int = 10  # optimiser trials between baseline re-flights (<= 10 % of the budget)
    rms_ratio: float = 1.25
    p_drop: float = 0.10
    resume_hint: str = "ksbo-mav tune --resume DIR"

    def due(self, journal: Journal) -> bool:
        """A baseline re-flight is due: ``every`` optimiser trials since the baseline or its last re-flight."""
        opt = journal.of("opt")
        if not opt or self.every <= 0:
            return False
        last = max([opt[0].trial, *(e.trial for e in journal.of("baseline"))])
        return sum(e.trial > last for e in opt) >= self.every

    def check(self, journal: Journal) -> None:
        """CampaignPaused, in plain words with the numbers, when the newest re-flight shows the vehicle changed."""
        first, again = journal.of("opt")[0], journal.of("baseline")
        if not again or again[-1].outcome != "ok":
            return
        last = again[-1]
        flights = last.trial - first.trial
        if first.rms is not None and last.rms is not None:
            if last.rms <= self.rms_ratio * first.rms:
                return
            what = f"the lap-2 RMS went from {first.rms:.2f} m to {last.rms:.2f} m"
        else:
            if last.P >= first.P - self.p_drop:
                return
            what = f"the score P went from {first.P:.3f} to {last.P:.3f}"
        raise CampaignPaused(f"drift: at the baseline gains {what} over {flights} flights (trial {last.trial}); the "
                             "gains did not cause this, the vehicle or its conditions changed (battery, propellers, "
                             f"payload, wind): check the vehicle, then `{self.resume_hint}`")
