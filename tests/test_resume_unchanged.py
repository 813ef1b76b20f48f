"""What a resume must find unchanged before it connects: the profile's search box and mission. A ``tune --wind``
campaign stored the figure-8 its wind plan scaled down; resuming it is not a changed profile (the plan is decided
again from the same wind and vehicle), but any other change to the mission still is."""

from __future__ import annotations

import pytest

from ksbo_mav.campaign.layout import CampaignDir
from ksbo_mav.campaign.resume import check_unchanged
from ksbo_mav.errors import InputError
from ksbo_mav.mav.gains import opt_bounds
from ksbo_mav.mav.mission import Mission
from ksbo_mav.profiles import load_profile


def _campaign(tmp_path, wind_mps, scale_by=1.0, **mission_changes):
    profile = load_profile("px4-copter")
    x0 = profile.default
    mission = Mission.from_profile(profile).to_dict()
    mission.update(scale=mission["scale"] * scale_by, scale2=mission["scale2"] * scale_by, **mission_changes)
    d = CampaignDir.at(tmp_path / "c")
    d.root.mkdir()
    d.write_settings({"config": {"dir": str(d.root), "wind_mps": wind_mps}, "profile": profile.name,
                      "baseline": {}, "x0": x0.tolist(), "bounds": opt_bounds(profile, x0).tolist(),
                      "mission": mission})
    return d


def test_a_wind_scaled_figure8_resumes(tmp_path):
    check_unchanged(_campaign(tmp_path, 5.0, scale_by=0.8), None, print)


def test_a_scaled_figure8_without_a_wind_plan_is_a_changed_profile(tmp_path):
    with pytest.raises(InputError, match="mission scale"):
        check_unchanged(_campaign(tmp_path, None, scale_by=0.8), None, print)


def test_a_wind_plan_does_not_excuse_another_change(tmp_path):
    with pytest.raises(InputError, match="mission period"):
        check_unchanged(_campaign(tmp_path, 5.0, scale_by=0.8, period=99.0), None, print)
