"""Baseline re-flights and the drift test: the watch on a campaign journal written here (the lap-2 RMS of the 3-D
figure-8s, the P of the planar task), and a campaign on our static simulator (its process, loopback UDP) that
re-flies the baseline at the cadence, never gives those flights to the optimiser and does not fire."""

from __future__ import annotations

import json

import pytest

from mav_tune_helpers import baseline, fresh_read, sim_and_endpoint

from ksbo_mav.campaign.drift import DriftWatch
from ksbo_mav.campaign.journal import Journal, JournalEntry
from ksbo_mav.cli import main
from ksbo_mav.errors import CampaignPaused
from ksbo_mav.mav.outcome import TrialOutcome


def _journal(tmp_path, flights: list[tuple[str, float, float | None]]) -> Journal:
    j = Journal(tmp_path / "journal.jsonl")
    for n, (kind, P, rms) in enumerate(flights):
        j.append(JournalEntry(kind, n, (0.0,), P, TrialOutcome.OK, f"trials/trial_{n:03d}.json", True, rms))
    return j


def test_a_vehicle_that_got_worse_at_the_same_gains_is_said_plainly(tmp_path) -> None:
    # the baseline at 0.21 m, optimiser trials, then the baseline again at 0.53 m, confirmed at once: it changed
    flights = [("opt", 0.5, 0.21)] + [("opt", 0.4, 0.3)] * 9 + [("baseline", -0.3, 0.53)]
    watch = DriftWatch(every=9, resume_hint="ksbo-mav tune --resume camp --udp 127.0.0.1:14550")
    j = _journal(tmp_path, flights[:10])
    assert watch.due(j)
    (tmp_path / "x").mkdir()
    j = _journal(tmp_path / "x", flights)
    assert watch.shows_change(j)
    (tmp_path / "y").mkdir()
    j = _journal(tmp_path / "y", flights + [("baseline", -0.3, 0.53)])
    with pytest.raises(CampaignPaused) as exc:
        watch.confirm(j)
    msg = str(exc.value)
    assert msg.startswith("drift: at the baseline gains the lap-2 RMS went from 0.21 m to 0.53 m over 11 flights")
    assert "the gains did not cause this" in msg and msg.endswith("`ksbo-mav tune --resume camp --udp 127.0.0.1:14550`")
    assert not watch.due(j)  # the re-flight just flown restarts the count


def test_flown_prior_trials_count_toward_the_cadence(tmp_path) -> None:
    watch = DriftWatch(every=7)
    assert not watch.due(_journal(tmp_path, [("opt", 0.5, 0.21)] + [("prior", 0.4, 0.3)] * 6))
    (tmp_path / "p").mkdir()
    assert watch.due(_journal(tmp_path / "p", [("opt", 0.5, 0.21)] + [("prior", 0.4, 0.3)] * 7))
    (tmp_path / "c").mkdir()  # confirmation flights are not trials of the search
    assert not watch.due(_journal(tmp_path / "c", [("opt", 0.5, 0.21)] + [("confirm", 0.4, 0.3)] * 8))


def test_the_same_vehicle_within_its_noise_does_not_fire(tmp_path) -> None:
    watch = DriftWatch(every=5)
    assert not watch.shows_change(_journal(tmp_path, [("opt", 0.5, 0.21)] + [("opt", 0.6, 0.2)] * 5
                                           + [("baseline", 0.45, 0.24)]))
    (tmp_path / "p").mkdir()  # the planar task: no RMS, P within the drop allowed
    assert not watch.shows_change(_journal(tmp_path / "p", [("opt", 0.20, None)] + [("opt", 0.8, None)] * 5
                                           + [("baseline", 0.15, None)]))
    (tmp_path / "q").mkdir()
    j = _journal(tmp_path / "q", [("opt", 0.20, None)] + [("opt", 0.8, None)] * 5 + [("baseline", 0.02, None)] * 2)
    with pytest.raises(CampaignPaused, match="the score P went from 0.200 to 0.020"):
        watch.confirm(j)


def test_noisy_re_flights_raise_the_threshold_and_a_trend_does_not(tmp_path) -> None:
    watch = DriftWatch()
    noisy = [("opt", 0.5, 0.20), ("baseline", 0.5, 0.26), ("baseline", 0.5, 0.17), ("baseline", 0.5, 0.27),
             ("baseline", 0.5, 0.18), ("baseline", 0.5, 0.27)]
    j = _journal(tmp_path, noisy)
    assert watch.threshold(j) > 0.35 and not watch.shows_change(j)  # 0.27 m is within this vehicle's noise
    (tmp_path / "t").mkdir()
    trend = [("opt", 0.5, 0.20), ("baseline", 0.5, 0.22), ("baseline", 0.5, 0.24), ("baseline", 0.5, 0.26),
             ("baseline", 0.5, 0.28)]
    j = _journal(tmp_path / "t", trend)
    assert watch.threshold(j) == pytest.approx(0.25) and watch.shows_change(j)  # a steady rise is not noise


def test_continue_mode_scores_against_the_baseline_now_from_its_re_flights(tmp_path) -> None:
    watch = DriftWatch(on_drift="continue")
    j = _journal(tmp_path, [("opt", 0.5, 0.20)] + [("opt", 0.6, 0.2)] * 3 + [("baseline", 0.0, 0.40)] * 2)
    watch.confirm(j)
    assert watch.fired and "from 0.20 m to 0.40 m" in watch.fired and watch.ref is not None
    # 0.45 m would be unsafe against the first flight (P < 0); against the baseline now it is near the baseline:
    # the newest re-flight (0.40 m, trial 5) carried one flight forward along the baselines' trend (Theil-Sen
    # slope 0.04 m per flight over trials 0, 4, 5)
    assert watch.reference_rms(j, 6) == pytest.approx(0.44)
    assert watch.corrected(j, 1 - 0.45 / 0.4, 0.45, 2.0) == pytest.approx(1 - 0.45 / 0.88)
    # a trial charged 0.3 for its roughness keeps that charge against the baseline now
    assert watch.corrected(j, 1 - (0.45 / 0.2 + 0.3) / 2, 0.45, 2.0, 0.3) == pytest.approx(1 - 0.45 / 0.88 - 0.15)
    (tmp_path / "b").mkdir()  # a vehicle that got better again: held at the newest re-flight, never lowered
    better = _journal(tmp_path / "b", [("opt", 0.5, 0.20), ("baseline", 0.0, 0.40), ("baseline", 0.1, 0.35),
                                       ("baseline", 0.2, 0.30)])
    watch.follow(better)
    assert watch.reference_rms(better, 9) == pytest.approx(0.30)
    (tmp_path / "p").mkdir()
    j = _journal(tmp_path / "p", [("opt", 0.3, None)] + [("opt", 0.6, None)] * 3 + [("baseline", 0.1, None)] * 2)
    watch = DriftWatch(on_drift="continue")
    watch.confirm(j)
    assert watch.corrected(j, -0.05, None, 2.0) == pytest.approx(0.15)


@pytest.mark.slow
@pytest.mark.network
@pytest.mark.timeout(600)
def test_a_static_vehicle_is_re_flown_at_the_cadence_and_the_campaign_goes_on(tmp_path, capsys) -> None:
    d = tmp_path / "camp"
    with sim_and_endpoint() as (sim, ep):
        rc = main(["tune", str(d), "--udp", f"127.0.0.1:{ep.port}", "--profile", "sim-planar", "--budget", "12",
                   "--baseline-every", "5"])
        err = capsys.readouterr().err
        assert rc == 0, err
        assert fresh_read(sim) == baseline()
    entries = [json.loads(x) for x in (d / "journal.jsonl").read_text().splitlines() if x.strip()]
    kinds = [e["kind"] for e in entries]
    opt = [e for e in entries if e["kind"] == "opt"]
    assert len(opt) == 12  # the budget: the re-flights are not optimiser trials
    again = [e for e in entries if e["kind"] == "baseline"]
    assert 1 <= len(again) <= 2 and all(e["x"] == opt[0]["x"] for e in again)
    assert kinds.index("baseline") == 6  # the baseline, 5 optimiser trials, then the baseline again
    assert "drift" not in err and err.count("the baseline gains again") == len(again)
    assert all(e["cond"]["flight"] == n for n, e in enumerate(entries))  # the conditions of every flight
    page = (d / "report" / "index.html").read_text()
    assert "baseline re-flight" in page


def test_the_start_is_the_mean_of_the_quiet_first_flights(tmp_path) -> None:
    # ArduCopter SITL, calm then 6 m/s: the first flight alone (0.211 m) hid the wind's +30 % within the floor;
    # with the quiet re-flight after it (0.183 m) the start is 0.197 m, and 0.26 m in the wind shows a change
    watch = DriftWatch(resume_hint="ksbo-mav tune --resume camp")
    flights = [("opt", 0.5, 0.211)] + [("opt", 0.6, 0.2)] * 7 + [("baseline", 0.56, 0.183)] + \
        [("opt", 0.7, 0.12)] * 11 + [("baseline", 0.38, 0.26)]
    j = _journal(tmp_path, flights)
    a = watch.anchor(j)
    assert (a.n, a.rms) == (2, pytest.approx(0.197))
    assert watch.shows_change(j)
    (tmp_path / "c").mkdir()
    with pytest.raises(CampaignPaused, match=r"from 0.20 m \(the mean of its first 2 flights\) to 0.26 m"):
        watch.confirm(_journal(tmp_path / "c", flights + [("baseline", 0.38, 0.26)]))
    (tmp_path / "t").mkdir()  # a trend: the second flight is not quiet, the start stays the first flight
    trend = _journal(tmp_path / "t", [("opt", 0.5, 0.20), ("baseline", 0.5, 0.24), ("baseline", 0.5, 0.28)])
    assert watch.anchor(trend).n == 1
