"""Which value a campaign setting takes: the command line's, else the stored campaign's (on --resume), else what
the vehicle profile implies, else the default — one row per setting and level, each computed by the code the
campaign runs (``ksbo_mav.campaign.config.resolve`` and its callers)."""

from __future__ import annotations

import pytest

from ksbo_mav.campaign import CampaignConfig, CampaignDir
from ksbo_mav.campaign.config import (BACKUP_BETA, optimizer_options, prior_kind, prior_size, resolve,
                                     with_profile_budget)
from ksbo_mav.cli import build_parser
from ksbo_mav.cli.tune import config_from_args
from ksbo_mav.profiles import load_profile

AP, PLANAR = load_profile("ardupilot-copter"), load_profile("sim-planar")


def _renamed(profile, name: str):
    """A user's own profile: the same vehicle under a name with no simulator of its class."""
    import dataclasses

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
     lambda tmp: optimizer_options("local", {}, "ksbo-adaptive", AP)["backup_beta"], BACKUP_BETA),
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
    ("budget", "command_line", lambda tmp: with_profile_budget(CampaignConfig(dir="x", budget=7), AP).budget, 7),
    ("budget", "profile (copter)", lambda tmp: with_profile_budget(CampaignConfig(dir="x"), AP).budget, 10),
    ("budget", "default", lambda tmp: with_profile_budget(CampaignConfig(dir="x"), PLANAR).budget, 30),
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
