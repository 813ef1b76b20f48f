"""Which value a campaign setting takes: the command line's, else the stored campaign's (on --resume), else what
the vehicle profile implies, else the default — one row per setting and level, each computed by the code the
campaign runs (``ksbo_mav.campaign.config.resolve`` and its callers)."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
from pathlib import Path

import pytest
from test_cli_first_run import closed_tcp_port, one_line_error, run

from ksbo_mav.campaign import CampaignConfig, CampaignDir
from ksbo_mav.campaign.config import (COVERED_TRIALS, MissionRate, optimizer_options, prior_kind, prior_size, resolve,
                                     settle)
from ksbo_mav.cli import build_parser
from ksbo_mav.campaign.settings import SETTING, SETTINGS, settings_markdown
from ksbo_mav.cli.tune import config_from_args
from ksbo_mav.errors import InputError
from ksbo_mav.profiles import load_profile

AP, PLANAR = load_profile("ardupilot-copter"), load_profile("sim-planar")
#: The copter profile with a mission rate of its own (the shipped profiles all fly at 50 Hz).
AP20 = dataclasses.replace(AP, mission_spec=dataclasses.replace(AP.mission_spec, rate_hz=20))
#: The copter profile with the trial's position step on ([campaign] trial_step).
AP_STEP = dataclasses.replace(AP, campaign_spec=dataclasses.replace(AP.campaign_spec, trial_step=True))


def _renamed(profile, name: str):
    """A user's own profile: the same vehicle under a name with no simulator of its class."""
    return dataclasses.replace(profile, name=name)


@pytest.mark.parametrize("levels,want", [
    ({"default": {"k": 1}}, 1),
    ({"profile": {"k": 2}, "default": {"k": 1}}, 2),
    ({"stored": {"k": 3}, "profile": {"k": 2}, "default": {"k": 1}}, 3),
    ({"command_line": {"k": 4}, "stored": {"k": 3}, "profile": {"k": 2}, "default": {"k": 1}}, 4),
    ({"command_line": {"k": None}, "profile": {"k": 2}}, None),  # null is a value: it turns the profile's off
    ({"command_line": {"other": 4}, "stored": {"k": 3}, "default": {"k": 1}}, 3),  # a level silent on k
])
def test_resolve_takes_the_highest_level_that_gives_a_value(levels, want):
    assert resolve(**levels)["k"] == want


def _resume_args(tmp_path, stored: dict, *cli: str):
    """Parsed `tune --resume DIR *cli` for a campaign stored with the settings ``stored``."""
    d = CampaignDir.at(tmp_path / "camp")
    d.root.mkdir()
    cfg = CampaignConfig(dir=str(d.root), **stored)
    d.write_settings({"config": cfg.to_dict(), "profile": "sim-planar", "baseline": {}, "x0": [], "bounds": []})
    return build_parser().parse_args(["tune", "--resume", str(d.root), "--udp", "127.0.0.1:14550", *cli])


def _new_args(tmp_path, *cli: str):
    return build_parser().parse_args(["tune", str(tmp_path / "new"), "--udp", "127.0.0.1:14550", *cli])


@pytest.mark.parametrize("setting,level,value,want", [
    # optimiser options: the user's over the profile's over the campaign's defaults
    ("backup_beta", "command_line",
     lambda tmp: optimizer_options("local", {"backup_beta": 2.0}, "ksbo-adaptive", AP)["backup_beta"], 2.0),
    ("backup_beta", "command_line (null turns it off)",
     lambda tmp: optimizer_options("local", {"backup_beta": None}, "ksbo-adaptive", AP)["backup_beta"], None),
    ("backup_beta", "profile",
     lambda tmp: optimizer_options("local", {}, "ksbo-adaptive", AP)["backup_beta"], COVERED_TRIALS["backup_beta"]),
    ("tr_success", "profile", lambda tmp: optimizer_options("local", {}, "ksbo-adaptive", AP)["tr_success"], 1),
    ("tr_success", "command_line",
     lambda tmp: optimizer_options("local", {"tr_success": 2}, "ksbo-adaptive", AP)["tr_success"], 2),
    ("backup_beta", "default (absent)",
     lambda tmp: optimizer_options("local", {}, "ksbo-adaptive", PLANAR).get("backup_beta", "absent"), "absent"),
    ("signal_std", "command_line",
     lambda tmp: optimizer_options("local", {"signal_std": 0.5}, "ksbo-adaptive", AP)["signal_std"], 0.5),
    ("signal_std", "default", lambda tmp: optimizer_options("local", {}, "ksbo-adaptive", AP)["signal_std"], 1.0),
    # the prior: the campaign's choice, else the profile's (simulator episodes for the planar vehicle), else local
    ("prior", "command_line", lambda tmp: prior_kind(CampaignConfig(dir="x", prior="none"), PLANAR), "none"),
    ("prior", "profile", lambda tmp: prior_kind(CampaignConfig(dir="x"), PLANAR), "sim"),
    ("prior", "profile (copter)", lambda tmp: prior_kind(CampaignConfig(dir="x"), AP), "sim"),
    ("prior", "default", lambda tmp: prior_kind(CampaignConfig(dir="x"), _renamed(AP, "my-hexa")), "local"),
    # the budget: the command line's, else the profile's [campaign] budget (one pack on the copters), else 30
    ("budget", "command_line", lambda tmp: settle(CampaignConfig(dir="x", budget=7), AP)[0].budget, 7),
    ("budget", "profile (copter)", lambda tmp: settle(CampaignConfig(dir="x"), AP)[0].budget, 10),
    ("budget", "default", lambda tmp: settle(CampaignConfig(dir="x"), PLANAR)[0].budget, 30),
    # the mission rate: --rate, else the rate the campaign flew at (a resume), else the profile's; only that last
    # one, on a new campaign, may the link check lower
    ("rate", "command_line",
     lambda tmp: settle(CampaignConfig(dir="x", rate_hz=25), AP20, {"mission": {"rate_hz": 10}})[1],
     MissionRate(25, lowerable=False)),
    ("rate", "stored", lambda tmp: settle(CampaignConfig(dir="x"), AP20, {"mission": {"rate_hz": 10}})[1],
     MissionRate(10, lowerable=False)),
    ("rate", "profile (a resume of a campaign.json without its mission)",
     lambda tmp: settle(CampaignConfig(dir="x"), AP20, {})[1], MissionRate(20, lowerable=False)),
    ("rate", "profile", lambda tmp: settle(CampaignConfig(dir="x"), AP20)[1], MissionRate(20, lowerable=True)),
    ("rate", "command_line (new campaign)", lambda tmp: settle(CampaignConfig(dir="x", rate_hz=10), AP20)[1],
     MissionRate(10, lowerable=False)),
    # the trial's position step: the command line's, else the stored campaign's, else the profile's; a campaign
    # stored before the setting existed flew none
    ("trial_step", "command_line",
     lambda tmp: settle(CampaignConfig(dir="x", trial_step=False), AP_STEP)[0].trial_step, False),
    ("trial_step", "stored",
     lambda tmp: settle(config_from_args(_resume_args(tmp, {"trial_step": True})), AP)[0].trial_step, True),
    ("trial_step", "stored (recorded before the setting)",
     lambda tmp: settle(CampaignConfig(dir="x"), AP_STEP, {"config": {"dir": "x"}})[0].trial_step, False),
    ("trial_step", "profile", lambda tmp: settle(CampaignConfig(dir="x"), AP_STEP)[0].trial_step, True),
    ("trial_step", "profile (default)", lambda tmp: settle(CampaignConfig(dir="x"), AP)[0].trial_step, False),
    ("n_prior", "command_line", lambda tmp: prior_size(CampaignConfig(dir="x", n_prior=5), "local"), 5),
    ("n_prior", "default (local)", lambda tmp: prior_size(CampaignConfig(dir="x"), "local"), 8),
    ("n_prior", "default (sim)", lambda tmp: prior_size(CampaignConfig(dir="x"), "sim"), 36),
    # settings a resume may change: the command line's over the stored campaign's over the default
    ("sysid", "command_line",
     lambda tmp: config_from_args(_resume_args(tmp, {"sysid": 7}, "--sysid", "9")).sysid, 9),
    ("sysid", "stored", lambda tmp: config_from_args(_resume_args(tmp, {"sysid": 7})).sysid, 7),
    ("sysid", "default", lambda tmp: config_from_args(_new_args(tmp)).sysid, None),
    ("accept", "command_line", lambda tmp: config_from_args(_resume_args(tmp, {}, "--accept")).accept, True),
    ("accept", "stored", lambda tmp: config_from_args(_resume_args(tmp, {"accept": True})).accept, True),
    ("accept", "default", lambda tmp: config_from_args(_new_args(tmp)).accept, False),
    ("onboard_guard", "command_line",
     lambda tmp: config_from_args(_resume_args(tmp, {}, "--no-onboard-guard")).onboard_guard, False),
    ("onboard_guard", "stored",
     lambda tmp: config_from_args(_resume_args(tmp, {"onboard_guard": False})).onboard_guard, False),
    ("onboard_guard", "default", lambda tmp: config_from_args(_new_args(tmp)).onboard_guard, True),
    ("validation", "command_line",
     lambda tmp: config_from_args(_resume_args(tmp, {"validation": "full"}, "--validation", "off")).validation, "off"),
    ("validation", "stored", lambda tmp: config_from_args(_resume_args(tmp, {"validation": "full"})).validation,
     "full"),
    ("validation", "default", lambda tmp: config_from_args(_new_args(tmp)).validation, "quick"),
    # --end has a command-line default, so the command line always gives it
    ("end", "command_line", lambda tmp: config_from_args(_resume_args(tmp, {"end": "hold"})).end, "land"),
    ("end", "command_line", lambda tmp: config_from_args(_resume_args(tmp, {}, "--end", "hold")).end, "hold"),
    # settings that define the campaign: the stored ones on resume (a different one is refused), else the default
    ("budget", "command_line", lambda tmp: config_from_args(_new_args(tmp, "--budget", "12")).budget, 12),
    ("budget", "stored", lambda tmp: config_from_args(_resume_args(tmp, {"budget": 12})).budget, 12),
    ("budget", "default (the profile's, once connected)", lambda tmp: config_from_args(_new_args(tmp)).budget, None),
])
def test_each_setting_at_each_level(tmp_path, setting, level, value, want):
    assert value(tmp_path) == want, f"{setting} from the {level}"


def test_the_whole_chain_command_line_over_stored_over_profile_over_default(tmp_path):
    """Through the command line and the vehicle's profile, as `tune` decides: each level where the ones above it
    are silent."""
    stored = {"budget": 12, "sysid": 7, "baseline_every": 3}
    cfg, _ = settle(config_from_args(_resume_args(tmp_path, stored, "--baseline-every", "5")), AP)
    assert (cfg.baseline_every, cfg.sysid, cfg.budget, cfg.compid) == (5, 7, 12, None)  # command line, stored
    cfg, _ = settle(config_from_args(_new_args(tmp_path)), AP)
    assert (cfg.budget, cfg.baseline_every) == (10, 7)  # the profile's, the default


#: A value each setting refuses (the test below checks that every declared setting has one).
BAD = {"dir": 7, "profile": "", "method": "ksb", "budget": 0, "seed": -1, "prior": "simulated", "n_prior": -3,
       "early_stop": "yes", "min_trials": 0, "confirm": -1, "warm_start": " ", "baseline_every": 2.5,
       "on_drift": "ignore", "rate_hz": 30,
       "validation": "on", "accept": 1, "end": "crash", "onboard_guard": "off", "settle_s": float("nan"),
       "trial_source": "radio", "trial_step": "yes", "wind_mps": -2.0, "sysid": 300, "compid": 0,
       "safety": {"z_min_m": "low"}, "options": ["beta"]}


def test_every_declared_setting_is_a_config_field_and_has_a_bad_value_here():
    assert [s.name for s in SETTINGS] == [f.name for f in dataclasses.fields(CampaignConfig)]
    assert set(BAD) == set(SETTING)


@pytest.mark.parametrize("name", list(BAD))
def test_a_bad_value_is_one_line_naming_the_setting_and_what_it_accepts(name):
    cfg = CampaignConfig(dir="x")
    setattr(cfg, name, BAD[name])
    with pytest.raises(InputError) as err:
        cfg.validate()
    msg = str(err.value)
    assert msg.startswith(f"{name} ") and "\n" not in msg
    assert f"must be {SETTING[name].accepts.describe()}, got {BAD[name]!r}" in msg


def test_campaign_json_with_a_bad_value_says_the_same_line(tmp_path):
    d = CampaignDir.at(tmp_path / "camp")
    with pytest.raises(InputError, match=r"^budget must be an integer in \[1, inf\), got 0$"):
        CampaignConfig.from_saved({"dir": str(d.root), "budget": 0}, str(d.config))


def test_an_older_campaign_json_with_a_retired_setting_still_loads(tmp_path):
    """``widen`` (a stage after the search, before the search box grew within it) is read past; a typo is not."""
    d = CampaignDir.at(tmp_path / "camp")
    assert CampaignConfig.from_saved({"dir": str(d.root), "widen": False}, str(d.config)).budget is None
    with pytest.raises(InputError, match="unknown campaign setting"):
        CampaignConfig.from_saved({"dir": str(d.root), "widen_": False}, str(d.config))


@pytest.mark.parametrize("bad,line", [
    (["--budget", "0"], "error: budget must be an integer in [1, inf), got 0"),
    (["--rate", "30"], "error: rate_hz (--rate) must be one of 50, 25, 20, 10, got 30"),
    (["--end", "crash"], "error: end must be one of land, hold, got 'crash'"),
    (["--prior", "simulated"], "error: prior must be one of auto, sim, local, none, got 'simulated'"),
    (["--on-drift", "ignore"], "error: on_drift (--on-drift) must be one of stop, continue, got 'ignore'"),
])
def test_bad_values_on_the_real_command_line_fail_before_connecting(tmp_path, bad, line):
    d = tmp_path / "camp"
    # A closed TCP port: had the tool connected first, the error would be about the connection instead.
    r = run("tune", str(d), "--tcp", f"127.0.0.1:{closed_tcp_port()}", *bad)
    one_line_error(r)
    assert r.stderr.strip() == line and not d.exists()


def test_a_resume_refuses_a_bad_value_as_such_before_comparing_it_with_the_stored_one(tmp_path):
    args = _resume_args(tmp_path, {"budget": 10}, "--budget", "0")
    with pytest.raises(InputError, match=r"^budget must be an integer in \[1, inf\), got 0$"):
        config_from_args(args)


def test_docs_settings_md_holds_the_declared_table():
    """docs/settings.md holds settings_markdown() between its markers (regenerate: see the page's head)."""
    text = (Path(__file__).parents[1] / "docs" / "settings.md").read_text()
    table = text.split("<!-- settings:begin -->\n", 1)[1].split("\n<!-- settings:end -->", 1)[0]
    assert table == settings_markdown()


def _tune_help() -> list[str]:
    env = {**os.environ, "COLUMNS": "120"}
    r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", "--help"], capture_output=True, text=True,
                       env=env, timeout=120)
    assert r.returncode == 0, r.stderr
    return r.stdout.splitlines()


def test_tune_help_groups_come_in_the_order_a_pilot_needs_them():
    titles = [ln[:-1] for ln in _tune_help() if ln.endswith(":") and not ln.startswith(" ")]
    assert titles == ["connection (exactly one)", "campaign directory", "profile and budget", "end of the campaign",
                      "optimiser", "mission and drift", "help"]
    lines = _tune_help()
    first = {opt: next(i for i, ln in enumerate(lines) if ln.startswith(f"  {opt}")) for opt in
             ("--udp", "--tcp", "--serial", "--udp-out", "DIR", "--resume", "--profile", "--budget", "--dry-run",
              "--method")}
    assert max(first[o] for o in ("--udp", "--tcp", "--serial", "--udp-out")) < first["DIR"] < first["--profile"]
    assert first["--budget"] < first["--dry-run"] < first["--method"]


def test_tune_help_gives_each_option_at_most_two_lines_at_120_columns():
    lines = _tune_help()
    start = next(i for i, ln in enumerate(lines) if ln == "connection (exactly one):")
    column = lines[start + 1].index("listen")  # where argparse starts the help text
    help_lines: dict[str, int] = {}
    option = None
    for ln in lines[start:]:
        if ln.startswith("  ") and not ln.startswith(" " * column):  # an option's own line
            option = ln.split()[0]
            help_lines[option] = 1 if ln[column:].strip() and ln[column - 1] == " " else 0
        elif option and ln.startswith(" " * column) and ln.strip():
            help_lines[option] += 1
    assert len(help_lines) >= 25 and all(1 <= n <= 2 for n in help_lines.values()), help_lines
