"""A finite battery on our simulator (its process, loopback UDP, lockstep; ``--battery MAH,CELLS,AMPS``): the
campaign reads SYS_STATUS/BATTERY_STATUS, stops before a trial the pack would not fit ("swap the battery, then
resume": exit 3, a normal stop), and when the autopilot's low-battery failsafe fires during a trial it records
the trial as interrupted (never given to the optimiser, never a crash), leaves the autopilot's RTL to land the
vehicle, writes the report and says "battery" with the resume command; a resume on a fresh pack completes the
budget. The vehicle's gains equal the snapshot after every stop."""

from __future__ import annotations

import json

import pytest

from mav_tune_helpers import baseline, fresh_read, sim_and_endpoint

from ksbo_mav.cli import main

pytestmark = [pytest.mark.network, pytest.mark.timeout(600)]


def _tune(capsys, args: list[str]) -> tuple[int, str]:
    rc = main(args)
    return rc, capsys.readouterr().err


def _journal(d) -> list[dict]:
    return [json.loads(line) for line in (d / "journal.jsonl").read_text().splitlines() if line.strip()]


def test_a_pack_that_would_not_fit_the_next_trial_lands_and_stops_to_be_resumed(tmp_path, capsys) -> None:
    d = tmp_path / "camp"
    with sim_and_endpoint("--battery", "200") as (sim, ep):
        rc, err = _tune(capsys, ["tune", str(d), "--udp", f"127.0.0.1:{ep.port}", "--profile", "sim-planar",
                                 "--budget", "10"])
        assert rc == 3, err
        last = err.strip().splitlines()[-1]
        assert last.startswith("stopped: battery: ") and "; then `ksbo-mav tune --resume" in last
        # a simulated pack (our simulator's SIM_* parameters): the setting that makes it last, not "swap the battery"
        assert "this is ksbo-mav sim's simulated pack (`--battery MAH`)" in last and "swap the battery" not in last
        lines = [line for line in err.splitlines() if line.startswith("battery: ")]
        assert lines and all("% left" in line for line in lines)  # the figures shown with the progress
        assert len(set(lines)) == len(lines)  # said when they change, not repeated after every trial
        assert fresh_read(sim) == baseline()
    entries = _journal(d)
    assert entries and all(e["kind"] != "failed" for e in entries)
    assert (d / "report" / "index.html").is_file()


@pytest.mark.slow  # default run: the battery stop and resume: the pack test beside it
def test_a_battery_failsafe_in_a_trial_is_an_interrupted_trial_and_resume_completes(tmp_path, capsys) -> None:
    d = tmp_path / "camp"
    with sim_and_endpoint("--battery", "100,3,12") as (sim, ep):  # the failsafe fires during the second trial
        rc, err = _tune(capsys, ["tune", str(d), "--udp", f"127.0.0.1:{ep.port}", "--profile", "sim-planar",
                                 "--budget", "4"])
        assert rc == 3, err
        last = err.strip().splitlines()[-1]
        assert last.startswith("stopped: battery: the autopilot's failsafe took over during trial 1")
        assert "recorded as interrupted" in last and "`ksbo-mav tune --resume" in last
        assert "ksbo-mav sim's simulated pack" in last
        assert "does not override it" in err and "landed and disarmed by the autopilot's failsafe" in err
        assert "\nlanding" not in err  # our LAND never replaced the autopilot's RTL
        assert fresh_read(sim) == baseline()
    entries = _journal(d)
    failed = [e for e in entries if e["kind"] == "failed"]
    assert [e["trial"] for e in failed] == [1] and failed[0]["outcome"] == "failsafe"
    assert all(e["outcome"] != "crash" for e in entries)
    assert (d / "report" / "index.html").is_file()
    n_before = len(entries)
    with sim_and_endpoint("--battery", "5000") as (sim, ep):  # a fresh pack
        rc, err = _tune(capsys, ["tune", "--resume", str(d), "--udp", f"127.0.0.1:{ep.port}"])
        assert rc == 0, err
        assert fresh_read(sim) == baseline()
        assert "resume: the baseline gains again" in err
    entries = _journal(d)
    assert entries[n_before]["kind"] == "baseline"  # after the swap the baseline flies first, tested for drift
    assert len([e for e in entries if e["kind"] == "opt"]) == 4  # the budget of 4 (the baseline included) met
    assert [e["trial"] for e in entries if e["kind"] == "failed"] == [1]
