"""Typed results of a campaign: the per-trial progress event and the final summary."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

from ksbo_mav.campaign.journal import Journal
from ksbo_mav.campaign.trial_rows import trial_role
from ksbo_task.flight import Flight


@dataclass(frozen=True)
class TrialEvent:
    """Sent to the progress display after every journalled trial."""

    kind: str  # journal kind: opt, prior, confirm
    flight: Flight
    role: str  # what the trial was, as the report's trial table says (baseline, re-flight of trial 6, ...)
    n_opt: int  # optimiser evaluations so far
    best_P: float  # best optimiser P so far (completed trials)
    n_unsafe: int  # P < 0 among optimiser evaluations
    n_aborted: int  # trials stopped by the monitor (recovered), all kinds
    n_crashed: int
    n_failed: int  # trials that ended for reasons unrelated to the gains

    @classmethod
    def of(cls, kind: str, flight: Flight, journal: Journal, x0: Any = None) -> "TrialEvent":
        """The event of the journal's last trial; ``x0``: the baseline gains (default: the first optimiser
        trial's, which is the baseline flight)."""
        opt = journal.of("opt")
        ok = [e.P for e in opt if e.outcome == "ok"]
        last = journal.entries[-1]
        before = [e for e in opt if e.trial != last.trial]
        x0 = x0 if x0 is not None else (opt[0].x if opt else last.x)
        return cls(kind=kind, flight=flight, role=trial_role(last, x0, before), n_opt=len(opt),
                   best_P=max(ok) if ok else float("-inf"),
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
