"""A campaign on our simulator whose vehicle changes (a wind step after 40 s of flight, over loopback UDP to the
simulator's own process): the drift test fires on the baseline re-flights and says so; by default the campaign
stops with the baseline restored and the message in the report, with ``--on-drift continue`` it flies the budget
with every later trial scored against the re-flown baseline. The conditions of each flight are in the journal."""

from __future__ import annotations

import json

import pytest

from mav_tune_helpers import baseline, fresh_read, sim_and_endpoint

from ksbo_mav.cli import main

pytestmark = [pytest.mark.network, pytest.mark.timeout(600)]

STILL = ("--wind", "0,0,20,0")  # no gusts: the same flights every run
STOP_WIND = (*STILL, "--wind-step", "40:1.0")
GO_WIND = ("--seed", "1", "--wind-step", "40:1.0")  # gusts, seeded: the approach is still made


def _entries(d):
    return [json.loads(x) for x in (d / "journal.jsonl").read_text().splitlines() if x.strip()]


@pytest.mark.slow  # default run: a stop's page and command: test_stops; drift: the drift benchmark
def test_a_vehicle_in_a_rising_wind_stops_the_campaign_with_the_numbers(tmp_path, capsys) -> None:
    d = tmp_path / "camp"
    with sim_and_endpoint(*STOP_WIND) as (sim, ep):
        rc = main(["tune", str(d), "--udp", f"127.0.0.1:{ep.port}", "--profile", "sim-planar", "--budget", "8",
                   "--baseline-every", "2"])
        err = " ".join(capsys.readouterr().err.split())  # the console wraps its lines
        assert rc == 3, err
        assert fresh_read(sim) == baseline()  # parameters = the snapshot
    # said with the numbers: the re-flight's score and the wind; the confirmation flown at once (or the baseline
    # gains no longer able to reach the start in this wind)
    assert "stopped: drift: " in err and "the gains did not cause this" in err
    assert "the score P went from" in err or "and now cannot" in err
    assert f"--resume {d}" in err
    entries = _entries(d)
    assert all(e["cond"]["wind_mps"] is not None for e in entries)
    assert json.loads((d / "drift.json").read_text())["on_drift"] == "stop"
    page = (d / "report" / "index.html").read_text()
    assert "Vehicle changed" in page and "the gains did not cause this" in page
    assert f"ksbo-mav report {d}" in page  # a stop writes the page at once; the plots are drawn on request
    assert main(["report", str(d)]) == 0
    assert (d / "report" / "conditions.png").is_file()


@pytest.mark.slow
def test_continue_mode_flies_the_budget_through_a_gusty_wind(tmp_path, capsys) -> None:
    # seeded gusts around 1 m/s: the baseline's P scatters 0.09-0.16 against 0.20 in calm air; the re-flights go
    # on at the cadence, the noise they show raises the test's threshold, and the budget is flown
    d = tmp_path / "camp"
    with sim_and_endpoint(*GO_WIND) as (sim, ep):
        rc = main(["tune", str(d), "--udp", f"127.0.0.1:{ep.port}", "--profile", "sim-planar", "--budget", "8",
                   "--baseline-every", "2", "--on-drift", "continue"])
        err = " ".join(capsys.readouterr().err.split())
        assert rc == 0, err
        assert fresh_read(sim) == baseline()
    entries = _entries(d)
    assert len([e for e in entries if e["kind"] == "opt"]) == 8
    assert len([e for e in entries if e["kind"] == "baseline"]) >= 2
    assert all(e["cond"]["wind_mps"] > 0.5 for e in entries if e["trial"] >= 3)
    page = (d / "report" / "index.html").read_text()
    assert "Same condition" in page and (d / "report" / "conditions.png").is_file()
    fired = (d / "drift.json").is_file()
    assert fired == ("continuing with every trial scored against the baseline as re-flown" in err)
    if fired:
        after = [e for e in entries if e["kind"] == "opt" and e["cond"].get("P_corrected") is not None]
        assert after and all(e["cond"]["P_corrected"] >= e["P"] for e in after)


@pytest.mark.slow
def test_a_copter_whose_drag_grows_stops_with_the_lap_rms(tmp_path, capsys) -> None:
    # the JSBSim copter's drag rising 30 % per minute of flight: its lap-2 RMS at the baseline gains rises with it
    # (the autopilot's loops do not make up for drag as they do for lost thrust); the test fires on the RMS
    d = tmp_path / "camp"
    with sim_and_endpoint("--vehicle", "copter3d", "--personality", "ardupilot", "--drag", "1,0.3") as (sim, ep):
        rc = main(["tune", str(d), "--udp", f"127.0.0.1:{ep.port}", "--budget", "6", "--prior", "none",
                   "--baseline-every", "2"])
        err = " ".join(capsys.readouterr().err.split())
        assert rc == 3, err
    assert "stopped: drift: at the baseline gains the lap-2 RMS went from" in err
    entries = _entries(d)
    base = [e["rms"] for e in entries if e["kind"] == "baseline" or e["trial"] == 0]
    assert len(base) == 3 and base[2] > 1.25 * base[0] and base[1] > 1.25 * base[0]  # re-flown, confirmed at once
    assert not (d / "result.json").exists() and (d / "report" / "index.html").is_file()
