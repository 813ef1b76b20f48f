"""The validation flights' journal (``validation.jsonl``): one fsynced line per flight, kept apart from the trial
journal so that no validation flight can ever reach the optimiser (its replay reads ``journal.jsonl`` only).

A flight belongs to a *comparison* (``pair``: "recommendation", or "trial 7" for a further candidate) and flies
either the baseline gains or the pair's (``gains``). A flight that ended for a reason unrelated to the gains (the
pilot, the link, a failsafe) is kept with ``counted`` false and flown again on resume.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from ksbo_mav.campaign.layout import append_line
from ksbo_mav.errors import InputError
from ksbo_mav.mav.outcome import TrialOutcome

BASELINE = "baseline"
RECOMMENDATION = "recommendation"


@dataclass(frozen=True)
class ValidationEntry:
    flight: int  # number of the validation flight (validation/flight_NNN.tlog)
    manoeuvre: str  # the manoeuvre's kind: steps, hold, auto_mission
    pair: str  # the comparison it belongs to: "recommendation" or "trial N"
    gains: str  # "baseline" or the pair's label
    x: tuple[float, ...]  # the gains flown (optimiser units)
    outcome: TrialOutcome
    metrics: dict[str, float]
    tlog: str
    restored: bool
    message: str = ""
    started_unix: float = 0.0
    ended_unix: float = 0.0
    cond: dict[str, Any] = field(default_factory=dict)  # wind (or why not), battery voltage

    @property
    def counted(self) -> bool:
        """The flight says something about its gains: completed, or aborted by the monitor (the gains' doing)."""
        return self.outcome == "ok" or self.outcome.gain_caused

    def to_json(self) -> str:
        d = asdict(self)
        d["outcome"] = self.outcome.value
        d["x"] = list(self.x)
        return json.dumps(d)

    @classmethod
    def parse(cls, doc: Any, where: str) -> "ValidationEntry":
        try:
            return cls(flight=int(doc["flight"]), manoeuvre=str(doc["manoeuvre"]), pair=str(doc["pair"]),
                       gains=str(doc["gains"]), x=tuple(float(v) for v in doc["x"]),
                       outcome=TrialOutcome(doc["outcome"]),
                       metrics={str(k): float(v) for k, v in (doc.get("metrics") or {}).items() if v is not None},
                       tlog=str(doc["tlog"]), restored=bool(doc["restored"]), message=str(doc.get("message", "")),
                       started_unix=float(doc.get("started_unix", 0.0)), ended_unix=float(doc.get("ended_unix", 0.0)),
                       cond=dict(doc.get("cond") or {}))
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"{where}: not a validation flight ({exc})") from None


class ValidationJournal:
    """Append-only, fsynced; a half-written last line (a killed process) is skipped."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.entries: list[ValidationEntry] = []
        if path.exists():
            lines = path.read_text().splitlines()
            for n, line in enumerate(lines, 1):
                if not line.strip():
                    continue
                try:
                    doc = json.loads(line)
                except json.JSONDecodeError:
                    if n == len(lines):
                        break
                    raise InputError(f"{path}:{n}: corrupt validation journal line") from None
                self.entries.append(ValidationEntry.parse(doc, f"{path}:{n}"))

    def append(self, entry: ValidationEntry) -> None:
        append_line(self.path, entry.to_json())
        self.entries.append(entry)

    def flown(self, pair: str, manoeuvre: str, gains: str) -> list[ValidationEntry]:
        """The counted flights of ``gains`` on ``manoeuvre`` in comparison ``pair``, in order."""
        return [e for e in self.entries if e.pair == pair and e.manoeuvre == manoeuvre and e.gains == gains
                and e.counted]

    def pairs(self) -> list[str]:
        """The comparisons flown, in the order they were started."""
        return list(dict.fromkeys(e.pair for e in self.entries))

    def next_flight(self) -> int:
        return max((e.flight for e in self.entries), default=-1) + 1
