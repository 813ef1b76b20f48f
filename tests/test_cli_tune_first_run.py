"""`tune` on a first run: every option is checked before anything is connected or written, a failed
start leaves no directory, --resume refuses options that would change the stored campaign, a damaged
campaign.json is one clear line, and --dry-run prints the flight plan. Real subprocesses (and the built-in
simulator over loopback UDP for the dry run)."""

from __future__ import annotations

import json

import pytest

from test_cli_first_run import closed_tcp_port, one_line_error, run

from ksbo_mav.campaign import CampaignConfig, CampaignDir
from ksbo_sim.process import SimProcess, free_udp_port


@pytest.mark.parametrize("bad,words", [
    (["--method", "ksb"], ["method must be one of ksbo, ksbo-adaptive", "got 'ksb'"]),
    (["--profile", "no-such-profile"], ["no-such-profile"]),
    (["--n-prior", "-3"], ["n_prior (--n-prior) must be an integer in [0, inf), got -3"]),
    (["--sysid", "300"], ["sysid must be an integer in [1, 255], got 300"]),
    (["--option", "backup_beta=-1"], ["option backup_beta=-1 is not allowed", "a number in (0, inf) or null"]),
    (["--option", "backup_beta"], ["KEY=VALUE"]),
])
def test_bad_options_refused_before_connecting_and_nothing_written(tmp_path, bad, words):
    d = tmp_path / "camp"
    # A closed TCP port: if the tool tried to connect first, the error would be about the connection instead.
    r = run("tune", str(d), "--tcp", f"127.0.0.1:{closed_tcp_port()}", *bad)
    one_line_error(r, *words)
    assert not d.exists()


def test_an_unknown_option_is_refused_with_the_list_of_options_one_line_each(tmp_path):
    d = tmp_path / "camp"
    r = run("tune", str(d), "--tcp", f"127.0.0.1:{closed_tcp_port()}", "--option", "bogus=1")
    assert r.returncode == 2 and "Traceback" not in r.stderr and not d.exists()
    lines = r.stderr.strip().splitlines()
    assert lines[0] == "error: unknown option(s) bogus; the options are:"
    assert len(lines) == 37 and lines[1].split()[0] == "beta" and any(ln.split()[0] == "backup_beta" for ln in lines)


def test_demo_refuses_a_bad_method_before_starting_the_simulator(tmp_path):
    d = tmp_path / "demo"
    r = run("demo", "--method", "ksb", "--dir", str(d), cwd=tmp_path)
    one_line_error(r, "method must be one of ksbo, ksbo-adaptive", "got 'ksb'")
    assert "starting the simulator" not in r.stdout  # nothing was started, flown or written
    assert not d.exists() and not (tmp_path / "ksbo-demo-runs").exists()


def test_failed_connection_leaves_no_directory(tmp_path):
    d = tmp_path / "camp"
    r = run("tune", str(d), "--udp", f"127.0.0.1:{free_udp_port()}", "--timeout", "1")
    one_line_error(r, "no vehicle heartbeat")
    assert not d.exists()


def _stored(tmp_path, **changes):
    d = CampaignDir.at(tmp_path / "camp")
    d.root.mkdir()
    cfg = CampaignConfig(dir=str(d.root), budget=10, method="ksbo")
    doc = {"config": cfg.to_dict(), "profile": "sim-planar", "baseline": {}, "x0": [], "bounds": []}
    doc.update(changes)
    d.write_settings(doc)
    return d


def test_resume_refuses_options_that_change_the_campaign(tmp_path):
    d = _stored(tmp_path)
    before = d.config.read_text()
    r = run("tune", "--resume", str(d.root), "--udp", f"127.0.0.1:{free_udp_port()}", "--method", "standard",
            "--budget", "12")
    one_line_error(r, "--method standard (campaign: ksbo)", "--budget 12 (campaign: 10)")
    assert d.config.read_text() == before


@pytest.mark.parametrize("damage,words", [
    (lambda doc: doc["config"].update(methd="ksbo"), ["unknown campaign setting", "methd"]),
    (lambda doc: doc.update(format=1), ["format 1", "format 2"]),
    (lambda doc: doc.pop("x0"), ["lacks 'x0'"]),
    (lambda doc: doc["config"].update(budget="many"), ["budget"]),
])
def test_damaged_campaign_json_is_one_line(tmp_path, damage, words):
    d = _stored(tmp_path)
    doc = json.loads(d.config.read_text())
    damage(doc)
    d.config.write_text(json.dumps(doc))
    r = run("tune", "--resume", str(d.root), "--udp", f"127.0.0.1:{free_udp_port()}")
    one_line_error(r, *words)


def test_not_json_campaign_is_one_line(tmp_path):
    d = _stored(tmp_path)
    d.config.write_text("{ not json")
    one_line_error(run("tune", "--resume", str(d.root), "--udp", f"127.0.0.1:{free_udp_port()}"),
                   "not readable campaign settings")


def _tune_against_sim(d, *args: str):
    """`ksbo-mav tune d --udp … *args` (a subprocess) against the built-in simulator, stopped afterwards."""
    port = free_udp_port()
    sim = SimProcess("--lockstep", out_port=port)
    try:
        return run("tune", str(d), "--udp", f"127.0.0.1:{port}", *args)
    finally:
        sim.stop()


@pytest.mark.network
def test_dry_run_prints_the_flight_plan_and_writes_nothing(tmp_path):
    d = tmp_path / "plan"
    r = _tune_against_sim(d, "--dry-run", "--budget", "12", "--prior", "local")
    assert r.returncode == 0, r.stderr
    for words in ("airspace: figure-8", "abort box: |north| <= 1.6 m, height 0.2-1.8 m (at the stopping point",
                  "flights: 23 at most (1 baseline + 8 prior + 11 optimiser + up to 2 baseline re-flights + 1 "
                  "confirmation)", "(+ prior 'local': 8 flown trials)",
                  "0.8 s approach to a moving start (up to 1 m/s)",
                  "approaches to the moving starts fly within 0.55 m of the figure-8 start", "batteries:",
                  "nothing was written"):
        assert words in r.stdout, r.stdout
    assert not d.exists()


@pytest.mark.slow  # default run: the ids' options: the other tests of this module
@pytest.mark.network
def test_sysid_and_compid_reach_the_wire(tmp_path):
    """--sysid/--compid are the ids the tool speaks with (they were parsed and dropped before)."""
    from ksbo_mav.mav.tlog import read_tlog

    d = tmp_path / "ids"
    r = _tune_against_sim(d, "--budget", "1", "--confirm", "0", "--prior", "none", "--sysid", "201", "--compid",
                          "42", "--end", "hold")
    assert r.returncode == 0, r.stderr
    sent = [rec.msg for rec in read_tlog(d / "trials" / "trial_000.tlog") if rec.sent]
    assert sent and {(m.get_srcSystem(), m.get_srcComponent()) for m in sent} == {(201, 42)}


def test_option_reaches_the_campaign_config_and_resume_keeps_it(tmp_path):
    from ksbo_mav.cli import build_parser
    from ksbo_mav.cli.tune import config_from_args
    from ksbo_mav.errors import InputError

    d = tmp_path / "camp"
    args = build_parser().parse_args(["tune", str(d), "--udp", "127.0.0.1:14550", "--method", "ksbo-adaptive",
                                      "--option", "backup_beta=0.5", "--option", "max_aborts=4"])
    cfg = config_from_args(args)
    assert cfg.options == {"backup_beta": 0.5, "max_aborts": 4}
    _stored(tmp_path, config=cfg.to_dict())  # the campaign as `tune` stores it (same directory)
    again = build_parser().parse_args(["tune", "--resume", str(d), "--udp", "127.0.0.1:14550"])
    assert config_from_args(again).options == cfg.options  # resumed as it was
    other = build_parser().parse_args(["tune", "--resume", str(d), "--udp", "127.0.0.1:14550",
                                       "--option", "backup_beta=1"])
    with pytest.raises(InputError, match="would change the campaign"):
        config_from_args(other)


def test_plan_names_the_options_the_profile_implies_and_the_users():
    """The campaign header says when the profile turned on backup exploration (and the user's options)."""
    from ksbo_mav.campaign.config import CampaignConfig
    from ksbo_mav.campaign.plan import options_note
    from ksbo_mav.profiles import load_profile

    ap, planar = load_profile("ardupilot-copter"), load_profile("sim-planar")
    assert CampaignConfig(dir="x").method == "ksbo-adaptive"  # the tune default
    note = options_note(CampaignConfig(dir="x", options={"max_aborts": 4}), ap)
    assert "backup_beta=0.5 (profile: the backup covers its trials)" in note and "max_aborts=4" in note
    assert "tr_success=1 (profile: the backup covers its trials)" in note  # the trust region's faster pace too
    assert options_note(CampaignConfig(dir="x", options={"backup_beta": 1.0, "tr_success": 2}), ap) == \
        "; options backup_beta=1.0, tr_success=2"
    assert options_note(CampaignConfig(dir="x"), planar) == ""
    assert options_note(CampaignConfig(dir="x", method="ksbo"), ap) == ""
