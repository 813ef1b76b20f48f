"""Validation flights in a campaign on the built-in simulator (JSBSim copter as ArduPilot, lockstep, its own process
over loopback UDP), small and quick: the tuner killed (SIGKILL) in the middle of the validation and resumed flies
exactly the missing flights, alternated A B A B; none reaches the optimiser's journal; the console and the report
give the verdict per manoeuvre; the vehicle ends with the snapshot's gains; `accept` refuses, in one line, a
recommendation the validation found worse (unless --force) and `validate` flies nothing twice."""

from __future__ import annotations

import json
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mav_tune_helpers import fresh_read, short_figure8, sim_and_endpoint

from ksbo_mav.campaign.validation_log import ValidationJournal
from ksbo_mav.campaign.verdict import judge_pairs, refusal
from ksbo_bench.kinds.fault_moments import profile as _fault_profile
from ksbo_mav.cli import main

pytestmark = [pytest.mark.network, pytest.mark.timeout(600)]

NAMES = ["PSC_NE_POS_P", "PSC_NE_VEL_P", "PSC_NE_VEL_I", "PSC_NE_VEL_D", "PSC_D_POS_P", "PSC_D_VEL_P"]


def _profile(tmp: Path) -> Path:
    """The fault matrix's copter profile (small validation manoeuvres) with a short figure-8 (4 m x 1 m, 8 s period,
    2 s lead-in): a trial takes a third of the profile's."""
    return short_figure8(_fault_profile(tmp))


def _lines(path: Path) -> list[dict]:
    return [json.loads(x) for x in path.read_text().splitlines() if x.strip()] if path.exists() else []


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """A campaign killed after three validation flights and resumed; yields (dir, sim, endpoint, outputs)."""
    tmp = tmp_path_factory.mktemp("validation")
    d = tmp / "c"
    prof = _profile(tmp)
    with sim_and_endpoint("--vehicle", "copter3d", "--personality", "ardupilot") as (sim, ep):
        before = fresh_read(sim, NAMES, None)
        cmd = [sys.executable, "-m", "ksbo_mav.cli", "tune", "--udp", f"127.0.0.1:{ep.port}"]
        proc = subprocess.Popen([*cmd, str(d), "--profile", str(prof), "--budget", "3", "--method", "random",
                                 "--prior", "none", "--end", "hold", "--no-onboard-guard"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + 400
        while len(_lines(d / "validation.jsonl")) < 3:
            assert proc.poll() is None, proc.communicate()[1][-3000:]
            assert time.monotonic() < deadline, "no validation flight"
            time.sleep(0.05)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        killed_at = len(_lines(d / "validation.jsonl"))
        resumed = subprocess.run([*cmd, "--resume", str(d), "--end", "hold"], capture_output=True, text=True,
                                 timeout=500)
        assert resumed.returncode == 0, resumed.stderr[-3000:]
        yield d, sim, ep, {"before": before, "killed_at": killed_at, "resumed": resumed}


@pytest.mark.slow
def test_resumed_validation_flies_each_slot_once_alternated(campaign):
    d, _, _, out = campaign
    flights = _lines(d / "validation.jsonl")
    assert 3 <= out["killed_at"] < len(flights) == 12  # 3 manoeuvres x 2 repeats x 2 gain sets
    for m in ("steps", "hold", "auto_mission"):
        mine = [f for f in flights if f["manoeuvre"] == m]
        assert [f["gains"] for f in mine] == ["baseline", "recommendation"] * 2  # A B A B
        assert all(f["outcome"] == "ok" and f["restored"] for f in mine)
    assert [f["flight"] for f in flights] == sorted({f["flight"] for f in flights})  # numbered once each
    for f in flights:
        assert Path(f["tlog"]).stat().st_size > 0
    # The flight the kill interrupted was not journalled; its tlog number is not reused.
    assert len(list((d / "validation").glob("flight_*.tlog"))) >= len(flights)


def test_no_validation_flight_reaches_the_optimiser(campaign):
    d, _, _, _ = campaign
    trials = _lines(d / "journal.jsonl")
    assert [t["kind"] for t in trials] == ["opt", "opt", "opt", "confirm"]
    records = {Path(t["record"]).with_suffix(".tlog").name for t in trials}
    assert not records & {Path(f["tlog"]).name for f in _lines(d / "validation.jsonl")}


def test_console_and_report_give_the_verdict_per_manoeuvre(campaign):
    d, _, _, out = campaign
    text = out["resumed"].stderr + out["resumed"].stdout
    verdicts = judge_pairs(ValidationJournal(d / "validation.jsonl").entries)
    assert "validation, recommendation against the baseline: " + verdicts[0].overall in text
    page = (d / "report" / "index.html").read_text()
    assert "<h2>Validation flights</h2>" in page and "hold_rms_m *" in page and "xtrack_rms_m *" in page
    for m, j in verdicts[0].judged.items():
        assert f"  {j.line(m)}" in text  # the console line, with the figures and the spread
        assert j.verdict in ("better", "no measurable change", "worse")


def test_the_realtime_benchmark_reads_the_campaigns_validation(campaign):
    """The campaign cell's ``validation`` analysis (the realtime-campaign sweep): the campaign's own verdicts per
    manoeuvre, every validation flight counted, the flights by label, the peak lean of each step flight."""
    from ksbo_bench.kinds.campaign_validation import figures

    d, _, _, _ = campaign
    fig = figures(d)
    entries = ValidationJournal(d / "validation.jsonl").entries
    verdicts = judge_pairs(entries)
    assert fig["validation_flights"] == len(entries) and fig["flights_by_label"]["confirm"] == 1
    assert {m: v["verdict"] for m, v in fig["verdicts"][verdicts[0].pair].items()} == \
        {m: j.verdict for m, j in verdicts[0].judged.items()}
    leans = [x for xs in fig["validation_step_leans"].values() for x in xs]
    assert leans and all(0 < x < 45 for x in leans)  # a 3 m step in this profile: a lean, never a flip
    assert len(fig["baseline_rms"]) >= 1
    ended = json.loads((d / "result.json").read_text())["search_end"]  # None: the stopping rule is off (random)
    assert fig["search_end_text"] == "–" if ended is None else fig["search_end_text"].startswith(("budget", "early"))


def test_the_vehicle_ends_with_the_snapshot_gains(campaign):
    _, sim, _, out = campaign
    assert fresh_read(sim, NAMES, None) == pytest.approx(out["before"], rel=1e-6)


def test_accept_refuses_a_recommendation_worse_in_validation_unless_forced(campaign, tmp_path, capsys):
    d, sim, ep, out = campaign
    worse = tmp_path / "worse"
    shutil.copytree(d, worse)
    journal = ValidationJournal(worse / "validation.jsonl")
    # In this copy the recommendation's hold drifted a metre further than flown: worse beyond the spread.
    for e in journal.entries:
        if e.manoeuvre == "hold" and e.gains == "recommendation":
            e.metrics["hold_rms_m"] = 1.0 + 2 * e.metrics["hold_rms_m"]
    (worse / "validation.jsonl").write_text("".join(e.to_json() + "\n" for e in journal.entries))
    line = refusal(judge_pairs(ValidationJournal(worse / "validation.jsonl").entries))
    assert line and "hold: worse" in line
    port = ["--udp", f"127.0.0.1:{ep.port}"]
    assert main(["accept", str(worse), *port]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "worse than the baseline" in err and "--force" in err
    assert fresh_read(sim, NAMES, None) == pytest.approx(out["before"], rel=1e-6)  # nothing written
    assert main(["accept", str(worse), *port, "--force"]) == 0
    assert "warning: the recommendation flew worse" in capsys.readouterr().out
    best = json.loads((worse / "result.json").read_text())["best"]["values"]
    assert fresh_read(sim, NAMES, None) == pytest.approx(best, rel=1e-5)
    assert main(["restore", str(worse), *port]) == 0
    assert fresh_read(sim, NAMES, None) == pytest.approx(out["before"], rel=1e-6)


def test_validate_later_flies_nothing_twice(campaign, capsys):
    d, sim, ep, out = campaign
    n = len(_lines(d / "validation.jsonl"))
    assert main(["validate", str(d), "--udp", f"127.0.0.1:{ep.port}", "--end", "hold"]) == 0
    assert len(_lines(d / "validation.jsonl")) == n
    text = capsys.readouterr().out
    assert "the vehicle holds the baseline gains" in text and "validation, recommendation against the baseline" in text
    assert not (d / "validation_start.json").exists()
    assert fresh_read(sim, NAMES, None) == pytest.approx(out["before"], rel=1e-6)


@pytest.mark.slow
def test_a_worse_recommendation_makes_validate_fly_the_next_candidate(campaign, tmp_path, capsys):
    """The campaign's recommendation replaced, in a copy, by sluggish gains (the position and velocity P halved):
    worse than the baseline on a manoeuvre, so `validate` flies the campaign's next best trial the same way, A B
    A B, and the verdict names the best candidate that is worse nowhere (or says that none is)."""
    d, sim, ep, out = campaign
    slow = tmp_path / "slow"
    shutil.copytree(d, slow)
    (slow / "validation.jsonl").unlink()
    shutil.rmtree(slow / "validation")
    result = json.loads((slow / "result.json").read_text())
    settings = json.loads((slow / "campaign.json").read_text())
    x = list(settings["x0"])
    x[0], x[1] = x[0] / 2, x[1] / 2  # PSC_NE_POS_P, PSC_NE_VEL_P
    result["best"]["x"] = x
    result["best"]["values"] = {n: v * (0.5 if n in ("PSC_NE_POS_P", "PSC_NE_VEL_P") else 1.0)
                                for n, v in settings["baseline"].items()}
    (slow / "result.json").write_text(json.dumps(result))
    assert main(["validate", str(slow), "--udp", f"127.0.0.1:{ep.port}", "--end", "hold"]) == 0
    text = capsys.readouterr().out
    verdicts = judge_pairs(ValidationJournal(slow / "validation.jsonl").entries)
    assert verdicts[0].pair == "recommendation" and verdicts[0].worse_on, text
    assert len(verdicts) == 2 and verdicts[1].pair.startswith("trial "), text
    flights = _lines(slow / "validation.jsonl")
    mine = [f["gains"] for f in flights if f["pair"] == verdicts[1].pair and f["manoeuvre"] == "hold"]
    assert mine == ["baseline", verdicts[1].pair] * 2
    named = "best candidate worse nowhere: " + verdicts[1].pair if not verdicts[1].worse_on else \
        "no candidate flown is worse nowhere"
    assert named in text and named in (slow / "report" / "index.html").read_text()
    assert fresh_read(sim, NAMES, None) == pytest.approx(out["before"], rel=1e-6)


@pytest.mark.slow
def test_a_pack_too_short_for_the_validation_stops_it_cleanly(tmp_path, capsys):
    """A pack (the simulator's, 1100 mAh at 10 A) that carries the tune but not its validation flights: they stop
    before the flight the pack would not fit, in one line naming `ksbo-mav validate`; the tune ends as usual (its
    result written, the baseline restored, landed) and exits 4: tuned, validation incomplete."""
    d = tmp_path / "c"
    prof = _profile(tmp_path)
    with sim_and_endpoint("--vehicle", "copter3d", "--personality", "ardupilot", "--battery", "1100") as (sim, ep):
        before = fresh_read(sim, NAMES, None)
        rc = main(["tune", str(d), "--udp", f"127.0.0.1:{ep.port}", "--profile", str(prof), "--budget", "3",
                   "--method", "random", "--prior", "none", "--no-onboard-guard"])
        err = capsys.readouterr().err
        assert rc == 4, err
        text = " ".join(err.split())
        assert "validation stopped: battery: " in text and f"`ksbo-mav validate {d}" in text, text[-3000:]
        assert "tuned; validation incomplete: stopped: battery: " in text
        assert "landed and disarmed" in text
        flights = _lines(d / "validation.jsonl")
        assert len(flights) < 12 and all(f["outcome"] == "ok" for f in flights)
        assert (d / "result.json").is_file()
        assert fresh_read(sim, NAMES, None) == pytest.approx(before, rel=1e-6)
