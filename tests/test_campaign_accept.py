"""Which confirmation flights keep `--accept` / `ksbo-mav accept` from leaving the best gains on the vehicle."""

from __future__ import annotations

import json

import pytest

from ksbo_mav.campaign.access import accept_campaign
from ksbo_mav.campaign.ending import confirm_failures
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


def test_journal_replay_answers_a_stress_reflight_only_from_a_journalled_stress_flight() -> None:
    """A resumed campaign replays its refly_stress re-flights from the journal; a journalled ordinary flight at the
    same gains does not answer a stress call (it flew another start), so replay diverges there and flies it."""
    import numpy as np

    from ksbo_mav.campaign.replay import JournalReplay
    from ksbo_mav.opt.evaluation import Evaluation, Outcome

    a, b = (0.1,), (0.2,)
    done = [JournalEntry(kind="opt", trial=0, x=a, P=0.5, outcome=TrialOutcome("ok"), record="", restored=True),
            JournalEntry(kind="opt", trial=1, x=b, P=-1.0, outcome=TrialOutcome("tilt"), record="", restored=True,
                         stress=True)]
    flown: list[tuple[float, bool]] = []
    fly = lambda x: flown.append((float(x[0]), False)) or Evaluation(0.7, Outcome.COMPLETE)  # noqa: E731
    fly_stress = lambda x: flown.append((float(x[0]), True)) or Evaluation(0.6, Outcome.COMPLETE)  # noqa: E731
    r = JournalReplay(done, fly, fly_stress=fly_stress)
    assert r(np.array(a)).value == 0.5
    ev = r.stress(np.array(b))
    assert ev.outcome is Outcome.ABORTED and flown == [] and r.replayed == 2
    assert r.stress(np.array(b)).value == 0.6 and flown == [(0.2, True)]  # past the journal: flown
    r2 = JournalReplay(done, fly, fly_stress=fly_stress)
    r2(np.array(a))
    assert r2(np.array(b)).value == 0.7 and r2.diverged_at == 1 and flown[-1] == (0.2, False)
    assert not hasattr(JournalReplay(done, fly), "stress")  # no stress start (a copter mission): ordinary re-flights
    assert JournalEntry.parse(json.loads(done[1].to_json()), "journal").stress
    assert not JournalEntry.parse({k: v for k, v in json.loads(done[0].to_json()).items() if k != "stress"},
                                  "journal").stress  # journals written before the field: ordinary flights
