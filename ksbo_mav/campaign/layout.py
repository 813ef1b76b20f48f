"""The campaign directory: the one place that knows its file names and reads/writes ``campaign.json``.

::

    campaign.json            versioned settings: config, profile, baseline, x0, optimiser bounds, identity
    snapshot/vehicle.*       every parameter before the first write (.param, .params, .json with hash)
    prior.json               the kernel-selection prior (simulator episodes), reused on resume
    journal.jsonl            one line per flown trial, appended and fsynced before the optimiser sees the value
    trials/trial_NNN.*       two-way tlog + JSON record of every trial
    result.json, report/     recommendation, before/after, plots
    accepted.param/.params, diff.txt   written on accept
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ksbo_mav.errors import InputError
from ksbo_mav.mav.params.snapshot import fsync_write

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
    def prior(self) -> Path:
        return self.root / "prior.json"

    @property
    def journal(self) -> Path:
        return self.root / "journal.jsonl"

    @property
    def trials(self) -> Path:
        return self.root / "trials"

    @property
    def result(self) -> Path:
        return self.root / "result.json"

    @property
    def report(self) -> Path:
        return self.root / "report"

    @property
    def accepted_stem(self) -> Path:
        return self.root / "accepted"

    @property
    def diff(self) -> Path:
        return self.root / "diff.txt"

    def trial_stem(self, index: int) -> Path:
        return self.trials / f"trial_{index:03d}"

    def exists(self) -> bool:
        """Whether a campaign was started here (settings or journal on disk)."""
        return self.config.exists() or self.journal.exists()

    def next_trial_index(self) -> int:
        """Number of the next trial (after every trial file on disk, recorded or interrupted)."""
        nums = [int(p.stem.split("_")[1]) for p in self.trials.glob("trial_*.*") if p.stem.split("_")[1].isdigit()]
        return max(nums) + 1 if nums else 0

    # --- campaign.json -------------------------------------------------------------------------------------------
    def write_settings(self, doc: dict[str, Any]) -> None:
        fsync_write(self.config, json.dumps({"format": FORMAT_VERSION, **doc}, indent=1))

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
