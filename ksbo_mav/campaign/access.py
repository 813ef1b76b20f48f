"""Restore and accept: write a campaign's baseline or best gains to the vehicle, verified by a fresh read.

Both work from disk alone (the snapshot and result.json), so they work after the tuner crashed or was killed.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from ksbo_mav.campaign.layout import CampaignDir, write_file
from ksbo_mav.campaign.onboard import remove_leftover_guard
from ksbo_mav.campaign.validation_log import ValidationJournal
from ksbo_mav.campaign.verdict import judge_pairs, refusal
from ksbo_mav.errors import InputError
from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.params import Snapshot, load_snapshot, write_param_files
from ksbo_mav.mav.stacks import autopilot_updated
from ksbo_mav.mav.vehicle import Vehicle


def check_identity(snap: Snapshot, v: Vehicle) -> None:
    """Refuse to write a snapshot's values to a different vehicle."""
    ident = v.identity.to_dict()
    for key in ("sysid", "autopilot", "vendor_id", "product_id"):
        if key in snap.identity and snap.identity[key] != ident[key]:
            raise InputError(f"snapshot {snap.path} is from another vehicle ({key} {snap.identity[key]} vs "
                             f"{ident[key]})")
    missing = [n for n in snap.gain_names if n not in v.params.table]
    if missing:
        raise InputError(f"vehicle lacks parameter(s) of the snapshot: {', '.join(missing)}")


def write_accepted(d: CampaignDir, base: dict[str, float], best: dict[str, float], v: Vehicle) -> None:
    types = {n: v.params.table[n].ptype for n in best}
    write_param_files(d.accepted_stem, best, types, v.identity.sysid, v.identity.compid)
    lines = [f"{n:<16} {base[n]:>14.7g} -> {best[n]:<14.7g} ({(best[n] - base[n]):+.4g})" for n in best]
    write_file(d.diff, "\n".join(["# parameter     baseline -> accepted", *lines]) + "\n")


def validation_refusal(d: CampaignDir) -> str | None:
    """One line when the validation flights found the recommendation worse than the baseline somewhere."""
    return refusal(judge_pairs(ValidationJournal(d.validation_journal).entries))


def restore_snapshot(path: str | Path, endpoint: Endpoint, log: Callable[[str], None] = print,
                     timeout: float = 15.0, sysid: int | None = None, compid: int | None = None) -> dict[str, float]:
    """Write a snapshot's tuned gains back and verify them by a fresh read (works after any crash)."""
    snap = load_snapshot(path)
    v = Vehicle.connect(endpoint, snap.profile, sysid=sysid, compid=compid, timeout=timeout, log=log)
    try:
        check_identity(snap, v)
        base = snap.baseline()
        v.restore(base)
        remove_leftover_guard(v, snap.params, log)
        put_back_mission(v, CampaignDir.at(path), log)
        others = [n for n, (val, _) in snap.params.items()
                  if n in v.params.table and n not in base and not autopilot_updated(v.stack.name, n)
                  and not n.startswith("SIM_")
                  and not np.isclose(v.params.table[n].value, val, rtol=1e-6, atol=1e-7)]
        if others:
            log(f"note: {len(others)} other parameter(s) differ from the snapshot and were left alone: "
                + ", ".join(others[:10]))
        return base
    finally:
        v.close()


def put_back_mission(v: Vehicle, d: CampaignDir, log: Callable[[str], None]) -> None:
    """The user's stored mission, kept on disk while a validation flight's AUTO mission replaced it (a tuner killed
    then), uploaded back (verified by the protocol) and its file removed."""
    if not d.user_mission.is_file():
        return
    from ksbo_mav.mav.mission_transfer import MissionTransfer, load_items

    items = load_items(d.user_mission)
    MissionTransfer(v.link).upload(items)
    d.user_mission.unlink()
    log(f"the vehicle's own mission put back ({len(items)} items; a validation flight had replaced it)")


def accept_campaign(path: str | Path, endpoint: Endpoint, log: Callable[[str], None] = print,
                    timeout: float = 15.0, sysid: int | None = None, compid: int | None = None,
                    force: bool = False) -> dict[str, float]:
    """Write a finished campaign's best gains (checked against the snapshot's trust region), verify, export.
    Refused (InputError, nothing connected) when a confirmation flight of those gains failed, unless ``force``."""
    d = CampaignDir.at(path)
    result = d.read_result()
    failed = result["best"].get("confirm_failures") or []
    if failed and not force:
        raise InputError(f"the recommended gains failed {len(failed)} of {len(result['best']['P_confirm_all'])} "
                         f"confirmation flight(s) ({'; '.join(failed)}); not written. --force writes them anyway")
    worse = validation_refusal(d)
    if worse and not force:
        raise InputError(f"{worse}; not written. --force writes them anyway")
    if worse:
        log(f"warning: {worse}; written anyway (--force)")
    snap = load_snapshot(d.snapshot)
    v = Vehicle.connect(endpoint, snap.profile, sysid=sysid, compid=compid, timeout=timeout, log=log)
    try:
        check_identity(snap, v)
        base = snap.baseline()
        best = {str(n): float(x) for n, x in result["best"]["values"].items()}
        v.check_trial_gains(v.gain_map.from_params(best), v.gain_map.from_params(base))
        v.restore(best)
        write_accepted(d, base, best, v)
        return best
    finally:
        v.close()
