"""The campaign journal: one fsynced JSON line per flown trial, the campaign's memory across crashes.

Kinds: ``opt`` (an optimiser evaluation; the first is the baseline), ``prior`` (a flown prior point),
``confirm`` (a re-flight of the recommendation) and ``failed`` (a trial that ended for a reason unrelated to the
gains — pilot, link, telemetry, a slow client: kept for the record, never given to the optimiser).
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ksbo_mav.campaign.layout import append_line
from ksbo_mav.errors import InputError
from ksbo_mav.mav.outcome import TrialOutcome
from ksbo_task.flight import Flight

KINDS = ("opt", "prior", "confirm", "failed", "baseline")
#: Role of each journal kind when nothing more specific applies (:func:`trial_role`).
ROLE = {"opt": "optimiser", "prior": "prior", "confirm": "confirmation", "failed": "interrupted",
        "baseline": "baseline re-flight"}


@dataclass(frozen=True)
class JournalEntry:
    kind: str
    trial: int
    x: tuple[float, ...]
    P: float
    outcome: TrialOutcome
    record: str
    restored: bool
    rms: float | None = None  # 3-D missions: lap-2 RMS tracking error (m)
    rough: float | None = None  # 3-D missions: lap-2 body-rate roughness (deg/s, ksbo_mav.smoothness)
    stress: bool = False  # flown from the hardest start (the optimiser's refly_stress re-flights)
    cond: dict[str, Any] | None = None  # wind, battery voltage, flight index (ksbo_mav.campaign.drift)

    @classmethod
    def of(cls, kind: str, f: Flight) -> "JournalEntry":
        return cls(kind=kind, trial=int(f.meta["trial"]), x=tuple(float(v) for v in f.gains), P=float(f.P),
                   outcome=TrialOutcome(f.outcome), record=str(f.meta["record"]), restored=bool(f.meta["restored"]),
                   rms=f.score.get("rms_lap2_m"), rough=f.score.get("rough_dps"),
                   stress=bool(f.meta.get("stress_start", False)))

    @classmethod
    def parse(cls, doc: Any, where: str) -> "JournalEntry":
        try:
            e = cls(kind=str(doc["kind"]), trial=int(doc["trial"]), x=tuple(float(v) for v in doc["x"]),
                    P=float(doc["P"]), outcome=TrialOutcome(doc["outcome"]), record=str(doc["record"]),
                    restored=bool(doc["restored"]), rms=None if doc.get("rms") is None else float(doc["rms"]),
                    rough=None if doc.get("rough") is None else float(doc["rough"]),
                    stress=bool(doc.get("stress", False)),
                    cond=dict(doc["cond"]) if isinstance(doc.get("cond"), dict) else None)
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"{where}: not a journal entry ({exc})") from None
        if e.kind not in KINDS:
            raise InputError(f"{where}: unknown journal entry kind {e.kind!r}")
        return e

    @property
    def scored(self) -> float:
        """The P the optimiser is given: drift-corrected when the campaign scored it against a re-flown baseline
        (:mod:`ksbo_mav.campaign.drift`, continue mode), else as flown."""
        if self.cond and self.cond.get("P_corrected") is not None:
            return float(self.cond["P_corrected"])
        return self.P

    def to_json(self) -> str:
        d = asdict(self)
        d["outcome"] = self.outcome.value
        d["x"] = list(self.x)
        return json.dumps(d)



class Journal:
    """Append-only JSON lines, each fsynced: a SIGKILL loses at most the trial being flown."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.entries: list[JournalEntry] = []
        if path.exists():
            lines = path.read_text().splitlines()
            for n, line in enumerate(lines, 1):
                if not line.strip():
                    continue
                try:
                    doc = json.loads(line)
                except json.JSONDecodeError:
                    if n == len(lines):  # a half-written last line: that trial was lost with the process
                        break
                    raise InputError(f"{path}:{n}: corrupt journal line") from None
                self.entries.append(JournalEntry.parse(doc, f"{path}:{n}"))

    def append(self, entry: JournalEntry) -> None:
        append_line(self.path, entry.to_json())
        self.entries.append(entry)

    def of(self, kind: str) -> list[JournalEntry]:
        return [e for e in self.entries if e.kind == kind]

    def has_trial(self, trial: int) -> bool:
        return any(e.trial == trial for e in self.entries)


def trial_role(e: JournalEntry, x0: np.ndarray, flown: list[JournalEntry]) -> str:
    """What trial ``e`` was, in words the console and the report share: ``x0`` the baseline gains (optimiser
    units), ``flown`` the optimiser's trials journalled before it. The journal's kinds lump these together: the
    optimiser's first evaluation is the baseline, a later optimiser trial at the baseline's gains is a baseline
    re-flight, one at an earlier trial's gains a re-flight of that trial."""
    if e.kind != "opt":
        return ROLE[e.kind]
    if not flown:
        return "baseline"
    if np.allclose(e.x, x0, rtol=1e-6, atol=1e-9):
        return "baseline re-flight"
    same = [f.trial for f in flown if np.allclose(e.x, f.x, rtol=1e-6, atol=1e-9)]
    return f"re-flight of trial {same[0]}" if same else ROLE["opt"]
