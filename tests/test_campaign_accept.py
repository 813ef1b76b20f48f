"""Which confirmation flights keep `--accept` / `ksbo-mav accept` from leaving the best gains on the vehicle."""

from __future__ import annotations

import json

import pytest

from ksbo_mav.campaign.access import accept_campaign, confirm_failures
from ksbo_mav.campaign.journal import JournalEntry
from ksbo_mav.errors import InputError
from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.outcome import TrialOutcome


def entry(trial: int, P: float, outcome: str = "ok") -> JournalEntry:
    return JournalEntry(kind="confirm", trial=trial, x=(0.1,), P=P, outcome=TrialOutcome(outcome), record="",
                        restored=True)


def test_only_aborted_crashed_or_unsafe_confirmations_count() -> None:
    assert confirm_failures([]) == []
    assert confirm_failures([entry(30, 0.8), entry(31, 0.0)]) == []  # P = 0 is safe (P_min = 0)
    got = confirm_failures([entry(30, 0.8), entry(31, -0.25), entry(32, -1.0, "tilt"), entry(33, -0.5, "crash")])
    assert got[0] == "confirmation trial 31: P = -0.250 < 0"
    assert got[1].startswith("confirmation trial 32: ") and "tilt" in got[1]
    assert got[2].startswith("confirmation trial 33: ") and len(got) == 3


def test_accept_refuses_before_connecting(tmp_path) -> None:
    (tmp_path / "result.json").write_text(json.dumps({"best": {
        "values": {"POS_X_P": 0.2}, "P_confirm_all": [0.8, -1.0],
        "confirm_failures": ["confirmation trial 31: aborted (tilt limit)"]}}))
    # port 9 (discard) on loopback: nothing answers - a refusal must come before any connection attempt
    with pytest.raises(InputError, match=r"failed 1 of 2 confirmation flight\(s\).*--force"):
        accept_campaign(tmp_path, Endpoint("udpout", "127.0.0.1", 9), timeout=0.5)
