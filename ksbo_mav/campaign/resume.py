"""What a resumed campaign must find unchanged: the search box and the mission its journalled trials were flown
with. A newer ksbo-mav or an edited profile file may change either (the 3-D figure-8 gained a lead-in); resuming
across such a change would mix trials of two different problems in one optimiser."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ksbo_mav.campaign.layout import CampaignDir
from ksbo_mav.errors import InputError
from ksbo_mav.mav.gains import opt_bounds
from ksbo_mav.mav.mission import Mission
from ksbo_mav.profiles import load_profile


#: Mission fields added after campaigns stored their mission, with the value the older ksbo-mav flew.
ADDED = {"start_speed": 0.0}


def check_unchanged(d: CampaignDir, profile_ref: str | None, log: Callable[[str], None]) -> None:
    """Before a resume connects: InputError (one line, naming what changed) if the campaign's profile
    (``profile_ref``, the file or name it was started with; None: the detected one stored in campaign.json) now
    gives another search box or mission than the stored ones. A campaign.json from before missions were stored
    is resumed with the profile's current mission, and ``log`` says so."""
    saved = d.read_settings()
    profile = load_profile(profile_ref or saved["profile"])
    changed = []
    old_box = np.asarray(saved["bounds"], dtype=float)
    box = opt_bounds(profile, np.asarray(saved["x0"], dtype=float))
    if old_box.shape != box.shape or not np.allclose(old_box, box, rtol=1e-9, atol=1e-12):
        changed.append(f"search box {saved['bounds']} -> {box.tolist()}")
    mission = Mission.from_profile(profile).to_dict()
    old = saved.get("mission")
    if old is None:
        log("campaign.json does not record its mission (made by an older ksbo-mav): flying the profile's current "
            f"one ({mission['kind']}, lead-in {mission['lead_in']:g} s)")
    elif (old := {**ADDED, **old, "rate_hz": mission["rate_hz"],  # the link check may lower the rate
                  **_wind_scaled(saved, old, mission)}) != mission:
        diff = [f"{k} {old.get(k)!r} -> {mission[k]!r}" for k in mission if old.get(k) != mission[k]]
        changed.append("mission " + ", ".join(diff))
    if changed:
        raise InputError(f"profile {profile.name} changed since this campaign started: {'; '.join(changed)}. Its "
                         "trials would not be comparable: finish it with the ksbo-mav and profile it was started "
                         "with, or start a new campaign")


def _wind_scaled(saved: dict, old: dict, mission: dict) -> dict:
    """The profile's figure-8 size, when the stored one is that size scaled down uniformly by the wind plan of a
    ``tune --wind`` campaign (:mod:`ksbo_mav.campaign.wind_preflight`, decided again on the resume), else ``{}``."""
    if (saved.get("config") or {}).get("wind_mps") is None or not mission.get("scale"):
        return {}
    k = float(old.get("scale", 0.0)) / float(mission["scale"])
    same = mission.get("scale2") and abs(float(old.get("scale2", 0.0)) / float(mission["scale2"]) - k) < 1e-9
    return {"scale": mission["scale"], "scale2": mission["scale2"]} if same and 0 < k <= 1 else {}
