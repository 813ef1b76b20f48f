"""What a campaign tells: the progress event after every journalled trial, and the final summary counted from the
journal (written to ``result.json`` once the tune is done, before the validation flights, and again at the end:
:func:`ksbo_mav.campaign.ending.write_result`)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ksbo_mav.campaign.journal import Journal, JournalEntry, trial_role
from ksbo_mav.campaign.layout import CampaignDir
from ksbo_mav.campaign.search_end import search_end
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
    #: The stopping rule's record and why the search ended (:mod:`ksbo_mav.campaign.search_end`); None: rule off.
    search_end: dict[str, Any] | None = None
    #: The validation flights' state: "pending" (the tune's first result, written before them), "complete",
    #: "incomplete" (``reason``, and the ``command`` that flies the rest) or "skipped" (``reason``).
    validation: dict[str, Any] | None = None
    #: The search box where it grew past the first one: ``bounds`` (d, 2) at the end and each ``growth`` (trial,
    #: dim, name, side, old, new); None: it never grew.
    box: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def __getitem__(self, key: str) -> Any:  # summary["best"] keeps working for dict-style readers
        return getattr(self, key)


def summarize(journal: Journal, result: Any, *, baseline_x: np.ndarray, base: dict[str, float], baseline_trial: int,
              best_params: dict[str, float], confirms: list[float], failures: list[str], unused: list[JournalEntry],
              accepted: bool, accept: bool, on_vehicle: dict[str, float], method: str, wall_s: float,
              d: CampaignDir, ended: str) -> CampaignSummary:
    """What the campaign did, safety counted three ways from the ``journal``.

    Args:
        result: the optimiser's result (``x`` (d,) the recommendation, ``fun`` its model mean, ``orders``).
        baseline_x, base: the baseline gain vector (d,) and its {autopilot parameter name: value}.
        best_params: the recommendation as {autopilot parameter name: value}.
        confirms, failures: P of the confirmation flights, and why any of them failed.
        unused: journalled trials a diverged replay could not use.
        accepted, accept: the best gains were left on the vehicle; --accept asked for that.
        on_vehicle: the tuned parameters on the vehicle now; ended: how the vehicle was left.
    """
    opt = journal.of("opt")
    gain_aborts = [e for e in journal.entries if e.outcome.gain_caused]
    return CampaignSummary(
        baseline={"x": baseline_x.tolist(), "values": base, "P": opt[0].P if opt else None,
                  "trial": baseline_trial, "rms_m": opt[0].rms if opt else None},
        best={"x": np.asarray(result.x, dtype=float).tolist(), "values": best_params, "P_model": float(result.fun),
              "P_confirm": float(np.mean(confirms)) if confirms else None, "P_confirm_all": confirms,
              "confirm_failures": failures,
              "unused_journal_trials": [e.trial for e in unused]},
        accepted=accepted, accept_refused="; ".join(failures) if accept else "",
        on_vehicle=on_vehicle, n_trials=len(journal.entries),
        n_unsafe=int(sum(e.P < 0 for e in opt)),
        n_aborted=sum(e.outcome != "crash" for e in gain_aborts),
        n_crashed=sum(e.outcome == "crash" for e in gain_aborts), n_failed=len(journal.of("failed")),
        method=method, orders=list(result.orders) if result.orders else None, wall_s=wall_s,
        dir=str(d.root), ended=ended,
        search_end=search_end((getattr(result, "info", None) or {}).get("stop"), opt[0] if opt else None,
                              len(confirms)),
        box=_grown((getattr(result, "info", None) or {}).get("box")))


def _grown(box: dict[str, Any] | None) -> dict[str, Any] | None:
    """The optimiser's search-box record when the box grew, else None."""
    return box if box and box.get("growth") else None
