"""Getting a campaign ready: connect with the campaign's profile, establish the baseline parameters, and (a new
campaign) snapshot every parameter and store the settings before anything is written to the vehicle."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from ksbo_mav.campaign.access import check_identity
from ksbo_mav.campaign.config import CampaignConfig, resolve
from ksbo_mav.campaign.layout import CampaignDir
from ksbo_mav.errors import InputError
from ksbo_mav.mav.gains import opt_bounds
from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.params import load_snapshot, write_snapshot
from ksbo_mav.mav.vehicle import Vehicle


def connect(cfg: CampaignConfig, d: CampaignDir, endpoint: Endpoint, resume: bool, timeout: float,
            log: Callable[[str], None]) -> Vehicle:
    """Connect with the campaign's profile: the one it names; on a resume else the one it was started with; else
    (None) the one :meth:`Vehicle.connect` detects from the vehicle's identity."""
    profile = resolve(command_line={"profile": cfg.profile} if cfg.profile else {},
                      stored={"profile": d.read_settings()["profile"]} if resume else {},
                      default={"profile": None})["profile"]
    return Vehicle.connect(endpoint, profile, sysid=cfg.sysid, compid=cfg.compid, timeout=timeout, log=log)


def baseline_params(v: Vehicle, d: CampaignDir, resume: bool, log: Callable[[str], None]) -> dict[str, float]:
    """{autopilot parameter name: value} of the baseline gains. A resume takes them from the snapshot (refused for
    another vehicle) and restores them if the vehicle holds others (an interrupted trial); a new campaign takes the
    vehicle's current ones, refused outside the profile's search box."""
    if resume:
        snap = load_snapshot(d.snapshot)
        check_identity(snap, v)
        base = snap.baseline()
        current = {n: v.params.read(n) for n in base}
        if any(not np.isclose(current[n], base[n], rtol=1e-6, atol=1e-7) for n in base):
            log("vehicle gains differ from the baseline (interrupted trial?): restoring the baseline")
            v.restore(base)
        else:
            log("baseline gains verified on the vehicle")
        return base
    base = {n: v.params.table[n].value for n in v.gain_map.param_names}
    try:
        v.profile.check_gains(v.gain_map.from_params(base))
    except InputError as exc:
        raise InputError(f"the vehicle's current gains are outside the profile's search box ({exc}); "
                         "set safe gains inside the box first") from None
    return base


def create_campaign(d: CampaignDir, cfg: CampaignConfig, v: Vehicle, base: dict[str, float],
                    log: Callable[[str], None]) -> None:
    """Snapshot every parameter, then the settings: the directory exists only from here on."""
    x0 = v.gain_map.from_params(base)
    snap = write_snapshot(d.snapshot_stem, v.identity.to_dict(), v.stack.name, v.gain_map.generation,
                          v.profile.name, list(v.gain_map.param_names), v.params.table)
    log(f"snapshot written: {snap.path.with_suffix('')}.{{param,params,json}}")
    d.write_settings({"config": cfg.to_dict(), "profile": v.profile.name, "baseline": base,
                      "x0": x0.tolist(), "bounds": opt_bounds(v.profile, x0).tolist(),
                      "mission": v.mission.to_dict(),
                      "identity": v.identity.to_dict(), "created_unix": time.time(),
                      "firmware": [line for line in (v.firmware_check.line, v.firmware_check.warning) if line]})
