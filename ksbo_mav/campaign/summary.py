"""Typed results of a campaign: the per-trial progress event and the final summary."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

from ksbo_mav.campaign.journal import Journal
from ksbo_mav.objective import Flight


@dataclass(frozen=True)
class TrialEvent:
    """Sent to the progress display after every journalled trial."""

    kind: str  # journal kind: opt, prior, confirm
    flight: Flight
    n_opt: int  # optimiser evaluations so far
    best_P: float  # best optimiser P so far (completed trials)
    n_unsafe: int  # P < 0 among optimiser evaluations
    n_aborted: int  # trials stopped by the monitor (recovered), all kinds
    n_crashed: int
    n_failed: int  # trials that ended for reasons unrelated to the gains

    @classmethod
    def of(cls, kind: str, flight: Flight, journal: Journal) -> "TrialEvent":
        opt = journal.of("opt")
        ok = [e.P for e in opt if e.outcome == "ok"]
        return cls(kind=kind, flight=flight, n_opt=len(opt), best_P=max(ok) if ok else float("-inf"),
                   n_unsafe=sum(e.P < 0 for e in opt),
                   n_aborted=sum(e.outcome.gain_caused and e.outcome != "crash" for e in journal.entries),
                   n_crashed=sum(e.outcome == "crash" for e in journal.entries), n_failed=len(journal.of("failed")))


@dataclass
class CampaignSummary:
    """What a finished campaign reports (also written to result.json). Safety is counted three ways: ``n_unsafe``
    (the paper's P < 0 among optimiser trials), ``n_aborted`` (monitor trips, vehicle recovered), ``n_crashed``;
    ``n_failed`` counts trials that said nothing about the gains."""

    baseline: dict[str, Any]
    best: dict[str, Any]
    accepted: bool
    on_vehicle: dict[str, float]
    n_trials: int
    n_unsafe: int
    n_aborted: int
    n_crashed: int
    n_failed: int
    method: str
    orders: list[int] | None
    wall_s: float
    dir: str
    ended: str  # "landed", "holding", "" (already on the ground)
    plots: dict[str, str] = field(default_factory=dict)
    #: With --accept: why the best gains were not left on the vehicle (a failed confirmation flight), else "".
    accept_refused: str = ""

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def __getitem__(self, key: str) -> Any:  # summary["best"] keeps working for dict-style readers
        return getattr(self, key)
