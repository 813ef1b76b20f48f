"""Campaigns against the simulator process over loopback UDP: improvement with the baseline restored
(fresh read), accept / restore commands, Ctrl-C, and SIGKILL followed by --resume and restore."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mav_tune_helpers import baseline, fresh_read, sim_and_endpoint

from ksbo_mav.cli import main
from ksbo_mav.campaign import Campaign, CampaignConfig
from ksbo_mav.errors import VehicleError

pytestmark = [pytest.mark.network]


def _journal(d: Path) -> list[dict]:
    p = d / "journal.jsonl"
    return [json.loads(line) for line in p.read_text().splitlines()] if p.exists() else []


def _wait_journal(d: Path, n: int, proc: subprocess.Popen, timeout: float = 120.0) -> None:
    deadline = time.monotonic() + timeout
    while len(_journal(d)) < n:
        assert proc.poll() is None, proc.stderr.read() if proc.stderr else "tuner exited early"
        assert time.monotonic() < deadline, "tuner made no progress"
        time.sleep(0.05)


def _tune_cmd(d: Path, port: int, *extra: str) -> list[str]:
    return [sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), "--udp", f"127.0.0.1:{port}", *extra]


@pytest.mark.slow  # default run: test_cli_demo; accept and restore on SITL: test_sitl_ardupilot
@pytest.mark.timeout(180)
def test_short_campaign_improves_then_restores_accept_and_restore_commands(tmp_path, capsys):
    d = tmp_path / "camp"
    with sim_and_endpoint() as (sim, ep):
        cfg = CampaignConfig(dir=str(d), budget=6, seed=0, prior="sim", end="hold")
        summary = Campaign(cfg, ep, log=lambda s: None).run()
        assert summary["best"]["P_confirm"] > summary["baseline"]["P"] + 0.2  # 0.19 -> ~0.8 in practice
        assert summary["n_trials"] == 7 and not summary["accepted"]
        assert fresh_read(sim) == pytest.approx(baseline(), rel=1e-6, abs=1e-7)
        for name in ("convergence", "trajectory"):
            assert Path(summary["plots"][name]).stat().st_size > 0
        # The safety plot exists only when something was unsafe, aborted or failed; else the report says so.
        nothing_bad = summary["n_unsafe"] == summary["n_aborted"] == summary["n_crashed"] == summary["n_failed"] == 0
        assert (summary["plots"]["safety"] == "none") == nothing_bad
        assert nothing_bad or Path(summary["plots"]["safety"]).stat().st_size > 0
        for f in ("campaign.json", "prior.json", "result.json", "snapshot/vehicle.param", "snapshot/vehicle.params"):
            assert (d / f).exists()
        # Every journalled trial has its record and tlog, and the record's score is the tlog's score.
        for e in _journal(d):
            rec = json.loads(Path(e["record"]).read_text())
            assert rec["score"]["P"] == e["P"] and Path(rec["tlog"]).stat().st_size > 0

        port = str(ep.port)
        assert main(["accept", str(d), "--udp", f"127.0.0.1:{port}"]) == 0
        best = summary["best"]["values"]
        assert fresh_read(sim) == pytest.approx(best, rel=1e-6)
        assert "->" in (d / "diff.txt").read_text() and (d / "accepted.params").exists()
        assert main(["restore", str(d), "--udp", f"127.0.0.1:{port}"]) == 0
        assert fresh_read(sim) == pytest.approx(baseline(), rel=1e-6, abs=1e-7)
        assert "verified" in capsys.readouterr().out


@pytest.mark.slow
@pytest.mark.timeout(180)
def test_campaign_with_accept_leaves_best_gains(tmp_path):
    with sim_and_endpoint() as (sim, ep):
        cfg = CampaignConfig(dir=str(tmp_path / "c"), budget=5, seed=1, prior="sim", accept=True)
        summary = Campaign(cfg, ep, log=lambda s: None).run()
        assert summary["accepted"]
        assert fresh_read(sim) == pytest.approx(summary["best"]["values"], rel=1e-6)
        assert (tmp_path / "c" / "accepted.param").exists()


@pytest.mark.slow
@pytest.mark.timeout(240)
def test_accept_refuses_gains_that_failed_their_confirmation_flight(tmp_path, capsys):
    """--accept leaves the best gains only if every confirmation flight of them completed safely: here the vehicle
    crashes as the confirmation's gains are written (SIM_CRASH_WRITES, set from a second connection once the last
    optimiser trial is journalled). The baseline is restored instead, the summary says why, `ksbo-mav accept`
    refuses before connecting, and `--force` writes them."""
    from ksbo_mav.mav.vehicle import Vehicle
    from ksbo_mav.mav.link import Endpoint

    d = tmp_path / "c"
    with sim_and_endpoint() as (sim, ep):
        def inject(event) -> None:
            if event.kind == "opt" and event.n_opt == cfg.budget:
                other = Vehicle.connect(Endpoint("udpout", "127.0.0.1", sim.port), "sim-planar", sysid=250,
                                        compid=190)
                try:
                    other.params.set_verified("SIM_CRASH_WRITES", 1.0, retries=8)
                finally:
                    other.close()

        cfg = CampaignConfig(dir=str(d), budget=4, seed=1, prior="none", accept=True, end="hold")
        summary = Campaign(cfg, ep, log=lambda s: None, progress=inject).run()
        confirm = [e for e in _journal(d) if e["kind"] == "confirm"]
        assert len(confirm) == 1 and confirm[0]["outcome"] == "crash"
        assert not summary.accepted and summary.accept_refused.startswith(f"confirmation trial {confirm[0]['trial']}")
        assert summary.best["confirm_failures"] and not (d / "accepted.param").exists()
        assert fresh_read(sim) == pytest.approx(baseline(), rel=1e-6, abs=1e-7)
        port = ["--udp", f"127.0.0.1:{ep.port}"]
        capsys.readouterr()
        assert main(["accept", str(d), *port]) == 2
        err = capsys.readouterr().err.strip()
        assert "failed 1 of 1 confirmation" in err and "--force" in err and "\n" not in err
        assert fresh_read(sim) == pytest.approx(baseline(), rel=1e-6, abs=1e-7)
        assert main(["accept", str(d), "--force", *port]) == 0
        assert fresh_read(sim) == pytest.approx(summary.best["values"], rel=1e-6)


@pytest.mark.timeout(180)
def test_sigint_mid_campaign_restores_baseline(tmp_path):
    d = tmp_path / "camp"
    with sim_and_endpoint() as (sim, ep):
        # Ctrl-C's default action in the child even when pytest runs as a background job (a shell starts those
        # with SIGINT ignored, the child would inherit that and never see the signal).
        proc = subprocess.Popen(_tune_cmd(d, ep.port, "--budget", "30"), stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True,
                                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        try:
            _wait_journal(d, 2, proc)
            time.sleep(0.5)  # well inside the next trial
            proc.send_signal(signal.SIGINT)
            out, err = proc.communicate(timeout=60)
        finally:
            if proc.poll() is None:
                proc.kill()
        assert proc.returncode == 130, err
        assert "baseline" in err and "restored" in err and "Traceback" not in err
        assert fresh_read(sim) == pytest.approx(baseline(), rel=1e-6, abs=1e-7)


@pytest.mark.timeout(240)
def test_sigkill_then_restore_and_resume_loses_and_reflies_nothing(tmp_path):
    d = tmp_path / "camp"
    with sim_and_endpoint() as (sim, ep):
        proc = subprocess.Popen(_tune_cmd(d, ep.port, "--budget", "6", "--end", "hold"),
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            _wait_journal(d, 3, proc)
            time.sleep(0.4)
            os.kill(proc.pid, signal.SIGKILL)
            proc.wait(10)
        finally:
            if proc.poll() is None:
                proc.kill()
        before = _journal(d)
        assert len(before) >= 3
        # The tool is gone; the snapshot alone brings the baseline back.
        assert main(["restore", str(d / "snapshot" / "vehicle.json"), "--udp", f"127.0.0.1:{ep.port}"]) == 0
        assert fresh_read(sim) == pytest.approx(baseline(), rel=1e-6, abs=1e-7)

        res = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", "--resume", str(d), "--udp",
                              f"127.0.0.1:{ep.port}"], capture_output=True, text=True, timeout=200)
        assert res.returncode == 0, res.stderr
        assert f"replaying {len([e for e in before if e['kind'] == 'opt'])} journalled" in res.stderr
        assert "differ from the journal" not in res.stderr  # the optimiser replayed deterministically
        after = _journal(d)
        assert after[: len(before)] == before  # nothing recorded was lost or rewritten
        opt = [e for e in after if e["kind"] == "opt"]
        assert len(opt) == 6  # the budget, counting the trials flown before the kill once
        trials = [e["trial"] for e in after]
        assert trials == sorted(set(trials))  # every trial flown once, numbered in order
        assert fresh_read(sim) == pytest.approx(baseline(), rel=1e-6, abs=1e-7)


@pytest.mark.slow
@pytest.mark.timeout(180)
def test_local_prior_is_flown_around_the_baseline_and_journalled(tmp_path):
    with sim_and_endpoint() as (sim, ep):
        cfg = CampaignConfig(dir=str(tmp_path / "c"), budget=3, seed=2, prior="local", n_prior=4, end="hold")
        summary = Campaign(cfg, ep, log=lambda s: None).run()
        entries = _journal(tmp_path / "c")
        # The baseline first (the reference and the optimiser's first point), then the prior, then the optimiser.
        assert [e["kind"] for e in entries] == ["opt"] + ["prior"] * 4 + ["opt"] * 2 + ["confirm"]
        assert summary["n_trials"] == 8
        x0 = summary["baseline"]["x"]
        from ksbo_mav.profiles import load_profile

        width = load_profile("sim-planar").bounds @ [-1.0, 1.0]
        for e in entries[1:5]:  # local LHS: within 10 % of the optimiser box around the baseline
            assert all(abs(a - b) <= 0.1 * w + 1e-9 for a, b, w in zip(e["x"], x0, width))
        assert fresh_read(sim) == pytest.approx(baseline(), rel=1e-6, abs=1e-7)


@pytest.mark.slow  # default run: test_pilot_takeover
@pytest.mark.timeout(180)
def test_pilot_mode_change_is_journalled_as_failed_not_as_a_gain_point(tmp_path):
    """A trial the pilot interrupts says nothing about its gains: journalled as "failed", never given to
    the optimiser; the campaign stops with the reason, baseline restored, and --resume starts cleanly."""
    from ksbo_mav.mav.link import Endpoint
    from ksbo_mav.mav.vehicle import Vehicle

    d = tmp_path / "camp"
    with sim_and_endpoint() as (sim, ep):
        other = Vehicle.connect(Endpoint("udpout", "127.0.0.1", sim.port), "sim-planar", sysid=250, compid=190)
        try:  # the pilot takes over 2 s into the baseline trial's figure-8
            other.params.set_verified("SIM_FAULT_AFTER", 5.0)
            other.params.set_verified("SIM_PILOT_MODE", 5)
        finally:
            other.close()
        cfg = CampaignConfig(dir=str(d), budget=4, seed=0, prior="none", end="hold")
        with pytest.raises(VehicleError, match="pilot changed the mode"):
            Campaign(cfg, ep, log=lambda s: None).run()
        entries = _journal(d)
        assert [e["kind"] for e in entries] == ["failed"] and entries[0]["outcome"] == "pilot"
        assert fresh_read(sim) == pytest.approx(baseline(), rel=1e-6, abs=1e-7)


@pytest.mark.slow
@pytest.mark.timeout(180)
def test_resume_flies_the_stored_profile_file_and_refuses_a_changed_box_or_mission(tmp_path, capsys):
    """A campaign started with ``--profile FILE`` resumes with that file; if the file's search box or mission
    changed since (an edited profile, a newer ksbo-mav), its journalled trials would not be comparable: one clear
    line, nothing flown or journalled."""
    from ksbo_mav.profiles import load_profile
    from importlib import resources

    src = resources.files("ksbo_params").joinpath("sim-planar.toml").read_text()
    prof = tmp_path / "mine.toml"
    prof.write_text(src)
    d = tmp_path / "camp"
    with sim_and_endpoint() as (sim, ep):
        cfg = CampaignConfig(dir=str(d), profile=str(prof), budget=2, seed=0, prior="none", confirm=0, end="hold")
        Campaign(cfg, ep, log=lambda s: None).run()
        saved = json.loads((d / "campaign.json").read_text())
        assert saved["mission"]["kind"] == "figure8-xz" and saved["mission"]["period"] == 6.0
        n = len(_journal(d))
        args = ["tune", "--resume", str(d), "--udp", f"127.0.0.1:{ep.port}"]
        assert main(args) == 0  # unchanged file: resumes (nothing left to fly)
        capsys.readouterr()
        assert len(_journal(d)) == n
        for old, new, word in (("max_step_fraction = 0.5", "max_step_fraction = 0.4", "search box"),
                               ("period_s = 6.0", "period_s = 7.0", "mission period 6.0 -> 7.0"),
                               ("start_speed_mps = 1.0", "start_speed_mps = 0.5", "mission start_speed 1.0 -> 0.5")):
            assert old in src
            prof.write_text(src.replace(old, new))
            load_profile(prof)  # a valid profile, only a different one
            assert main(args) == 2
            err = capsys.readouterr().err.strip()  # (tune's progress display may leave an empty line before it)
            assert err.startswith("error: ") and "\n" not in err and word in err and "changed since" in err
            assert len(_journal(d)) == n
        # A campaign made before trials could start moving flew them from hover: not the profile's mission now.
        prof.write_text(src)
        del saved["mission"]["start_speed"]
        (d / "campaign.json").write_text(json.dumps(saved))
        assert main(args) == 2
        assert "mission start_speed 0.0 -> 1.0" in capsys.readouterr().err
        assert fresh_read(sim) == pytest.approx(baseline(), rel=1e-6, abs=1e-7)
