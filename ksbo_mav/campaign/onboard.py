"""The campaign's onboard guard: installed before the first trial, removed when the campaign ends however it ends,
and by ``ksbo-mav restore``.

The guard is opt-in for now (``--onboard-guard``): installed, it still hides the vehicle's arming refusal text and
keeps the trial's start marker out of ArduPilot's DataFlash log. Asked for on ArduPilot (and the built-in simulator,
which simulates it) without scripting, the campaign stops before flying, naming what to set; without it the console
says what that leaves, and the settings, hence the report, record it. PX4 runs no scripts: there is no guard to
install, and the console says so; its own link-loss failsafe (checked by :mod:`ksbo_mav.campaign.link_loss_policy`) is
the backstop.
"""

from __future__ import annotations

from collections.abc import Callable

from ksbo_mav.errors import KsboError
from ksbo_mav.mav.guard_script import config_for, new_config_id
from ksbo_mav.mav.monitor import limits_from_profile
from ksbo_mav.mav.onboard_guard import GCS_SYSID_PARAMS, GuardUnavailable, OnboardGuard
from ksbo_mav.mav.vehicle import Vehicle

WITHOUT = ("flying WITHOUT the onboard guard (--onboard-guard installs it): if the link is lost during a trial, "
           "the trial gains keep flying until it comes back")


def install_guard(v: Vehicle, wanted: bool, base: dict[str, float], safety: dict[str, float],
                  log: Callable[[str], None]) -> None:
    """Install the guard of the baseline ``base`` and the monitor's limits (``safety`` overrides applied) as
    ``v.guard``; :class:`GuardUnavailable` (one line) when it cannot run and was not waived."""
    if not wanted:
        log(f"warning: {WITHOUT}")
        return
    if v.stack.name == "px4":
        log("onboard guard: PX4 runs no scripts; its link-loss failsafe is the backstop")
        return
    guard = OnboardGuard(v.link, v.params, v.cmd, log)
    try:
        guard.install(config_for(limits_from_profile(v.profile, safety), v.heartbeat_timeout, base,
                                 new_config_id()))
    except GuardUnavailable as exc:
        raise GuardUnavailable(f"{exc} [to fly without it: --no-onboard-guard]") from None
    v.guard = guard


def remove_guard(v: Vehicle, log: Callable[[str], None]) -> None:
    """Remove the campaign's guard (never raises: a removal that fails is said, the script stays inert)."""
    guard, v.guard = v.guard, None
    if guard is None:
        return
    try:
        guard.remove()
    except KsboError as exc:
        log(f"warning: the onboard guard was not fully removed ({exc}); `ksbo-mav restore DIR` tries again")


def remove_leftover_guard(v: Vehicle, snapshot_params: dict[str, tuple[float, int]],
                          log: Callable[[str], None]) -> None:
    """``ksbo-mav restore``: remove a guard an earlier campaign left (its script and parameters) on a vehicle that
    runs scripts, and give ``MAV_GCS_SYSID`` (``SYSID_MYGCS``) the snapshot's value back where a campaign set it to
    this tuner's id."""
    table = v.params.table
    if v.stack.name == "px4" or "SCR_ENABLE" not in table or table["SCR_ENABLE"].value != 1:
        return
    try:
        OnboardGuard(v.link, v.params, v.cmd, log).remove()
        for name in GCS_SYSID_PARAMS:
            if name in table and name in snapshot_params and table[name].value == v.link.mav.srcSystem \
                    and table[name].value != snapshot_params[name][0]:
                v.params.set_verified(name, snapshot_params[name][0])
                log(f"onboard guard: {name} back to {snapshot_params[name][0]:g}")
    except KsboError as exc:
        log(f"warning: onboard guard not removed: {exc}")
