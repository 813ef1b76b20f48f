"""The campaign's flown trials as report rows: console number, role, gains, P, lap RMS, outcome.

Read back from the campaign directory (journal, settings, tlogs), so the report shows what was logged. A row's
role is :func:`~ksbo_mav.campaign.journal.trial_role`, the words the console uses too.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ksbo_mav.campaign.journal import Journal, JournalEntry, trial_role
from ksbo_mav.campaign.layout import CampaignDir

#: The four ways safety is counted (never lumped together).
SAFETY = ("unsafe (P < 0)", "aborted by the monitor", "crashed", "interrupted (not the gains)")


@dataclass(frozen=True)
class TrialRow:
    """One flown trial. ``values``: gains in the vehicle's units, by vehicle parameter name; ``rms``: lap-2 RMS
    position error (m) of a completed trial, else None; ``note``: for an interrupted trial, what happened (its
    record's message: e.g. what the vehicle and the onboard guard did while the link was down)."""

    entry: JournalEntry
    role: str
    values: dict[str, float]
    rms: float | None
    note: str = ""

    @property
    def trial(self) -> int:
        return self.entry.trial

    @property
    def kind(self) -> str:
        return self.entry.kind

    @property
    def P(self) -> float:
        return self.entry.P

    @property
    def safety(self) -> tuple[str, ...]:
        """Which of :data:`SAFETY` this trial counts in, as the console counts: an optimiser trial the monitor
        aborted is also unsafe (its P < 0, as in the paper); a confirmation with P < 0 is not an unsafe search."""
        o = self.entry.outcome
        return tuple(label for label, flag in zip(SAFETY, (
            self.kind == "opt" and self.P < 0, o.gain_caused and o != "crash", o == "crash", self.kind == "failed"))
            if flag)

    @property
    def outcome_text(self) -> str:
        """completed / aborted by the monitor / crashed / interrupted / ended early, with the outcome's text."""
        o = self.entry.outcome
        if self.kind == "failed":
            return f"interrupted ({o.text}; not the gains)" + (f": {self.note}" if self.note else "")
        if o == "ok":
            return "completed" + ("; P < 0" if self.P < 0 else "")
        if o == "crash":
            return "crashed"
        return f"aborted by the monitor ({o.text})" if o.gain_caused else f"ended early ({o.text})"


@dataclass(frozen=True)
class CampaignRecord:
    """What the report needs from a campaign directory: settings, rows, gain names and the unit conversion."""

    settings: dict[str, Any]
    rows: list[TrialRow]
    names: list[str]  # vehicle parameter names of the tuned gains, in the optimiser's order
    scale: np.ndarray  # (d,) optimiser value = vehicle value * scale

    @property
    def bounds(self) -> np.ndarray:
        """(d, 2) the search box in the vehicle's units."""
        return np.asarray(self.settings["bounds"], dtype=float) / self.scale[:, None]

    @property
    def x0(self) -> np.ndarray:
        return np.asarray(self.settings["x0"], dtype=float)

    def to_params(self, x: Any) -> np.ndarray:
        return np.asarray(x, dtype=float) / self.scale

    def of(self, *roles: str) -> list[TrialRow]:
        return [r for r in self.rows if r.role in roles]


def read_campaign(d: CampaignDir, rms: bool = True) -> CampaignRecord:
    """Settings and trial rows of the campaign in ``d`` (InputError, one line, when it is not one). ``rms``:
    recompute the planar mission's lap RMS from the tlogs (about 0.2 s a trial)."""
    settings = d.read_settings()
    if d.prior.is_file():  # a simulated prior: what "auto" became, and its size, for the report's header
        try:
            settings["prior_simulated"] = len(json.loads(d.prior.read_text()).get("y", []))
        except (OSError, ValueError):
            pass
    names = list(settings["baseline"])
    base = np.array([settings["baseline"][n] for n in names], dtype=float)
    x0 = np.asarray(settings["x0"], dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where((base != 0) & np.isfinite(x0 / base), x0 / base, 1.0)
    scale = np.where(scale > 0, scale, 1.0)
    rows: list[TrialRow] = []
    flown: list[JournalEntry] = []
    for e in Journal(d.journal).entries:
        role = trial_role(e, x0, flown)
        if e.kind == "opt":
            flown.append(e)
        rows.append(TrialRow(e, role, dict(zip(names, (np.asarray(e.x) / scale).tolist())),
                             _rms(e) if rms else e.rms, _note(e)))
    return CampaignRecord(settings, rows, names, scale)


def _note(e: JournalEntry) -> str:
    """An interrupted trial's message from its record ("" for the others, or when the record cannot be read)."""
    if e.kind != "failed":
        return ""
    try:
        return str(json.loads(Path(e.record).read_text(encoding="utf-8")).get("message") or "")
    except (OSError, ValueError, AttributeError):
        return ""


def _rms(e: JournalEntry) -> float | None:
    """Lap-2 RMS position error: journalled for 3-D missions, recomputed from the tlog for the planar one; none for
    an interrupted trial (its flight says nothing about the gains, e.g. setpoints sent late)."""
    if e.kind == "failed":
        return None
    if e.rms is not None or e.outcome != "ok":
        return e.rms
    try:
        traj, info = trajectory(e.record)
    except Exception:  # a damaged or missing tlog: the row shows no RMS rather than losing the report
        return None
    lo, hi = info["window"]
    sel = (traj.steps >= lo) & (traj.steps < hi)
    err = traj.states[sel][:, (0, 2)] - traj.refs[sel][:, (0, 2)]
    return float(np.sqrt(np.mean(np.sum(err * err, axis=1)))) if len(err) and np.isfinite(err).all() else None


def trajectory(record: str) -> tuple[Any, dict[str, Any]]:
    """The trial's :class:`~ksbo_task.flight.Trajectory` and recorder info, replayed from its tlog."""
    from ksbo_mav.mav.tlog import read_tlog
    from ksbo_mav.mav.trajectory import trajectory_from_tlog

    traj, info, _ = trajectory_from_tlog(read_tlog(CampaignDir.tlog_of(record)))
    return traj, info
