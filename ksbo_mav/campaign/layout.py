"""The campaign directory: the one place that knows its file and folder names, and the one way the campaign
writes them (:func:`write_file` replaces a file atomically and durably, :func:`append_line` appends a fsynced
line); it reads and writes ``campaign.json`` itself.

::

    campaign.json            versioned settings: config, profile, baseline, x0, optimiser bounds, identity
    snapshot/vehicle.*       every parameter before the first write (.param, .params, .json with hash)
    link.json                the link check's figures: the campaign's start and each resume
    prior.json               the kernel-selection prior (simulator episodes), reused on resume
    journal.jsonl            one line per flown trial, appended and fsynced before the optimiser sees the value
    drift.json               the drift test's verdict, once it fired
    trials/trial_NNN.*       two-way tlog + JSON record of every trial
    validation.jsonl         one line per validation flight (never the optimiser's), appended and fsynced
    validation/flight_NNN.tlog   two-way tlog of every validation flight
    validation_start.json    the gains `ksbo-mav validate` found on the vehicle (put back at its end)
    validation/user_mission.json   the vehicle's stored mission while an AUTO validation flight replaces it
    result.json              recommendation, before/after, safety counts; written once the tune is done, before
                             the validation flights, and again at the end (``validation``: their state)
    recommended.param/.params   the recommendation, exported with that first result.json
    stopped.json             how a campaign that stopped before its end stopped, and the command that continues
    report/                  index.html and its plots (NAME.png)
    accepted.param/.params, diff.txt   written on accept
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ksbo_mav.errors import InputError
from ksbo_mav.jsonio import fsync_write

#: Suffix of a trial's two-way telemetry log, beside its JSON record (``trials/trial_NNN.tlog``).
TLOG_SUFFIX = ".tlog"

#: Version of campaign.json written by this tool; older or newer files are refused with a message.
FORMAT_VERSION = 2


@dataclass(frozen=True)
class CampaignDir:
    """Paths of one campaign directory (nothing is created until something is written)."""

    root: Path

    @classmethod
    def at(cls, path: str | Path) -> "CampaignDir":
        return cls(Path(path))

    @property
    def config(self) -> Path:
        return self.root / "campaign.json"

    @property
    def snapshot_stem(self) -> Path:
        return self.root / "snapshot" / "vehicle"

    @property
    def snapshot(self) -> Path:
        """The snapshot's JSON file (identity, every parameter, checksum)."""
        return self.snapshot_stem.with_suffix(".json")

    @property
    def link(self) -> Path:
        return self.root / "link.json"

    @property
    def prior(self) -> Path:
        return self.root / "prior.json"

    @property
    def journal(self) -> Path:
        return self.root / "journal.jsonl"

    @property
    def drift(self) -> Path:
        return self.root / "drift.json"

    @property
    def trials(self) -> Path:
        return self.root / "trials"

    @property
    def validation_journal(self) -> Path:
        return self.root / "validation.jsonl"

    @property
    def validation_flights(self) -> Path:
        return self.root / "validation"

    def validation_tlog(self, index: int) -> Path:
        return self.validation_flights / f"flight_{index:03d}{TLOG_SUFFIX}"

    @property
    def user_mission(self) -> Path:
        return self.validation_flights / "user_mission.json"

    @property
    def validation_start(self) -> Path:
        return self.root / "validation_start.json"

    @property
    def result(self) -> Path:
        return self.root / "result.json"

    @property
    def stopped(self) -> Path:
        return self.root / "stopped.json"

    @property
    def recommended_stem(self) -> Path:
        return self.root / "recommended"

    @property
    def report(self) -> Path:
        return self.root / "report"

    @property
    def report_page(self) -> Path:
        return self.report / "index.html"

    def report_plot(self, name: str) -> Path:
        """``report/NAME.png``: one of the report's plots (convergence, gains, trajectory, safety, conditions)."""
        return self.report / f"{name}.png"

    @property
    def accepted_stem(self) -> Path:
        return self.root / "accepted"

    @property
    def diff(self) -> Path:
        return self.root / "diff.txt"

    def trial_stem(self, index: int) -> Path:
        return self.trials / f"trial_{index:03d}"

    def trial_tlog(self, index: int) -> Path:
        return self.trial_stem(index).with_suffix(TLOG_SUFFIX)

    @staticmethod
    def tlog_of(record: str | Path) -> Path:
        """The tlog written beside a trial's JSON ``record`` (the path its journal entry names)."""
        return Path(record).with_suffix(TLOG_SUFFIX)

    def exists(self) -> bool:
        """Whether a campaign was started here (settings or journal on disk)."""
        return self.config.exists() or self.journal.exists()

    def next_trial_index(self) -> int:
        """Number of the next trial (after every trial file on disk, recorded or interrupted)."""
        nums = [int(p.stem.split("_")[1]) for p in self.trials.glob("trial_*.*") if p.stem.split("_")[1].isdigit()]
        return max(nums) + 1 if nums else 0

    # --- campaign.json -------------------------------------------------------------------------------------------
    def write_settings(self, doc: dict[str, Any]) -> None:
        write_file(self.config, json.dumps({"format": FORMAT_VERSION, **doc}, indent=1))

    def read_settings(self) -> dict[str, Any]:
        """campaign.json, checked: InputError (one line) for a missing, unreadable or foreign-version file."""
        try:
            doc = json.loads(self.config.read_text())
        except FileNotFoundError:
            raise InputError(f"{self.root} holds no campaign to resume (no campaign.json)") from None
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise InputError(f"{self.config} is not readable campaign settings ({exc})") from None
        if not isinstance(doc, dict):
            raise InputError(f"{self.config} is not a JSON object")
        version = doc.get("format", 1)
        if version != FORMAT_VERSION:
            raise InputError(f"{self.config} has format {version!r}; this ksbo-mav reads format {FORMAT_VERSION} "
                             "(finish or restore that campaign with the version that started it)")
        for key in ("config", "profile", "baseline", "x0", "bounds"):
            if key not in doc:
                raise InputError(f"{self.config} lacks {key!r}")
        return doc

    def read_result(self) -> dict[str, Any]:
        try:
            return json.loads(self.result.read_text())
        except (OSError, json.JSONDecodeError):
            raise InputError(f"{self.root} has no readable result.json (campaign not finished?)") from None


def write_file(path: Path, text: str) -> None:
    """Replace ``path`` (a file of a campaign directory) with ``text``, atomically and durably: after a crash it holds
    the old text or the new one, never a mix."""
    fsync_write(path, text)


def append_line(path: Path, line: str) -> None:
    """Append ``line`` and a newline to ``path`` and fsync it: once this returns, the line survives a crash (a
    process killed mid-write leaves at most a half last line, which the readers skip)."""
    with open(path, "a") as fh:
        fh.write(line + "\n")
        fh.flush()
        os.fsync(fh.fileno())
