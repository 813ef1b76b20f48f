"""How a campaign stopped and the one command that continues it, kept on disk (``stopped.json``) for the console,
the report and ``ksbo-mav restore``.

Every path that ends a campaign before its end — a pause (the pack, an autopilot failsafe, a vehicle that landed by
itself while the link was down), a pilot's take-over, a lost link, Ctrl-C, an unexpected error, and a tuner killed
outright (found by ``ksbo-mav restore``) — leaves the report of what was flown and this record. What continues
depends on how far the campaign got: before the tune's result is on disk, ``ksbo-mav tune --resume`` (it restores the
baseline first, then flies only what the journal lacks); once it is, only validation flights are missing and
``ksbo-mav validate`` flies them. A resume that starts flying removes the record.

Exit statuses of ``tune`` and ``validate`` (:data:`EXIT`), also in ``tune --help`` and docs/flight-checklist.md.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass
from typing import Any

from ksbo_mav.campaign.layout import CampaignDir, write_file
from ksbo_mav.mav.link import Endpoint

#: Exit statuses: tuned (and validated, where asked); an error (nothing usable, or the campaign stopped for a
#: reason to fix); a pause to resume (the pack, an autopilot failsafe, a vehicle that landed by itself); tuned, with
#: the validation flights incomplete (``validate`` flies the rest); Ctrl-C.
EXIT = {"ok": 0, "error": 2, "paused": 3, "unvalidated": 4, "interrupted": 130}
EXIT_TEXT = ("exit status: 0 tuned (and validated); 2 an error, the campaign stopped (the report says what was flown "
             "and the command that continues); 3 paused (the pack, an autopilot failsafe, a vehicle that landed by "
             "itself): resume it; 4 tuned, validation incomplete: `ksbo-mav validate DIR` flies the rest; "
             "130 Ctrl-C")


def connection_option(ep: Endpoint) -> str:
    """The command-line option that reaches ``ep`` again (``--tcp 127.0.0.1:5760``)."""
    kind = {"udpout": "udp-out"}.get(ep.kind, ep.kind)
    return f"--{kind} {ep.host}:{ep.port}" if ep.kind in ("udp", "udpout", "tcp") else f"--serial {ep.host}:{ep.baud}"


def continue_command(d: CampaignDir, ep: Endpoint, phase: str | None = None) -> str:
    """The one command that continues the campaign in ``d``: ``tune --resume`` before the tune's result is on disk,
    ``validate`` after it (``phase`` "tune" or "validation"; default: read from ``d``)."""
    phase = phase or next_phase(d) or "tune"
    verb = f"tune --resume {d.root}" if phase == "tune" else f"validate {d.root}"
    return f"ksbo-mav {verb} {connection_option(ep)}"


def next_phase(d: CampaignDir) -> str | None:
    """What the campaign in ``d`` still lacks: "tune" (no result yet), "validation" (the tune's result is written,
    validation flights are pending or incomplete), None (finished)."""
    try:
        result = json.loads(d.result.read_text())
    except (OSError, ValueError):
        return "tune" if d.exists() else None
    state = ((result or {}).get("validation") or {}).get("state")
    return "validation" if state in ("pending", "incomplete") else None


@dataclass(frozen=True)
class StopRecord:
    """``stopped.json``: why, when (Unix s), what continues, the exit status given, and an unexpected error's
    traceback (for a bug report)."""

    reason: str
    command: str
    phase: str
    exit: int
    at: float
    traceback: str = ""


def write_stop(d: CampaignDir, reason: str, command: str, phase: str, exit_status: int, traceback: str = "") -> None:
    if d.exists():
        write_file(d.stopped, json.dumps(asdict(StopRecord(reason, command, phase, exit_status, time.time(),
                                                            traceback)), indent=1))


def read_stop(d: CampaignDir) -> StopRecord | None:
    try:
        doc = json.loads(d.stopped.read_text())
        return StopRecord(**{k: doc[k] for k in ("reason", "command", "phase", "exit", "at")},
                          traceback=str(doc.get("traceback", "")))
    except (OSError, ValueError, KeyError, TypeError):
        return None


def clear_stop(d: CampaignDir) -> None:
    d.stopped.unlink(missing_ok=True)


def set_validation_state(d: CampaignDir, state: dict[str, Any]) -> None:
    """result.json's ``validation`` block replaced by ``state`` (nothing without a result on disk)."""
    try:
        result = json.loads(d.result.read_text())
    except (OSError, ValueError):
        return
    write_file(d.result, json.dumps({**result, "validation": state}, indent=1))
