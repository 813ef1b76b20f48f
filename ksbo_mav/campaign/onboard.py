"""The campaign's onboard guard: installed before the first trial, removed when the campaign ends however it ends,
and by ``ksbo-mav restore``.

The guard is on by default. On ArduPilot (and the built-in simulator, which simulates it) without scripting, the
campaign stops before flying, naming what to set; flown without it (``--no-onboard-guard``) the console says what
that leaves, and the settings, hence the report, record it. PX4 runs no scripts: there is no guard to
install, and the console says so; its own link-loss failsafe (checked by :mod:`ksbo_mav.campaign.link_loss_policy`) is
the backstop.

With ``trial_source`` onboard the guard is rendered with the campaign's figure-8 and flies every trial's figure-8
itself (:mod:`ksbo_mav.mav.onboard_trial`); without a guard, or on the planar task's figure-8, the tuner streams
it as before, and says so.
"""

from __future__ import annotations

from collections.abc import Callable

from ksbo_mav.errors import KsboError
from ksbo_mav.mav.guard_script import config_for, figure8_for, new_config_id
from ksbo_mav.mav.monitor import limits_from_profile
from ksbo_mav.mav.onboard_guard import GCS_SYSID_PARAMS, GuardUnavailable, OnboardGuard
from ksbo_mav.mav.vehicle import Vehicle

WITHOUT = ("flying WITHOUT the onboard guard (--no-onboard-guard): if the link is lost during a trial, "
           "the trial gains keep flying until it comes back")


#: The guard trips on board at this multiple of the profile's tracking-error limit: the tuner's monitor (same
#: limit as ever) acts first where the telemetry reaches it; the guard's margin is for a link too thin to.
TRACK_MARGIN = 1.5
STREAMED = "trials: the figure-8 streamed from the ground"


def install_guard(v: Vehicle, wanted: bool, base: dict[str, float], safety: dict[str, float],
                  log: Callable[[str], None], on_board: bool = False) -> None:
    """Install the guard of the baseline ``base`` and the monitor's limits (``safety`` overrides applied) as
    ``v.guard``, flying the figure-8 itself when ``on_board``; :class:`GuardUnavailable` (one line) when it cannot
    run and was not waived."""
    if not wanted:
        log(f"warning: {WITHOUT}")
        if on_board:
            log(f"{STREAMED} (flying it on board needs the onboard guard)")
        return
    if v.stack.name == "px4":
        log("onboard guard: PX4 runs no scripts; its link-loss failsafe is the backstop")
        if on_board:
            log(f"{STREAMED} (PX4 runs no scripts)")
        return
    limits = limits_from_profile(v.profile, safety)
    figure8 = None
    if on_board and v.mission.kind != "figure8-ne":
        log(f"{STREAMED} (only the 3-D figure-8 is flown on board, not {v.mission.kind})")
    elif on_board:
        figure8 = figure8_for(v.mission, TRACK_MARGIN * limits.tracking_error_max)
    guard = OnboardGuard(v.link, v.params, v.cmd, log)
    try:
        guard.install(config_for(limits, guard_link_timeout(v, log), base, new_config_id(), figure8=figure8))
    except GuardUnavailable as exc:
        raise GuardUnavailable(f"{exc} [to fly without it: --no-onboard-guard]") from None
    v.guard = guard
    if figure8 is not None:
        log(f"trials: the figure-8 flown on board by the onboard guard (a target every {figure8.tick_ms} ms; the "
            "link carries the start, the gains and the telemetry to score)")


def guard_link_timeout(v: Vehicle, log: Callable[[str], None]) -> float:
    """The guard's link timeout in seconds of *vehicle* time. The ground's monitor counts the profile's
    ``heartbeat_timeout_s`` on the wall clock, the guard on the vehicle's: where the vehicle's clock runs faster
    (a SITL at a speed-up; the rate is measured, never taken below 1) the guard's timeout is scaled by it, so both
    give up after the same wall time and a tuner a busy computer holds up for a few tenths of a second does not
    look lost to a guard that sees ten times as much vehicle time go by. On a real vehicle the rate is 1."""
    clock = v.telemetry.clock
    rate = max(1.0, clock.rate) if clock.valid else 1.0
    if rate < 1.2:  # real time, give or take the estimate's noise
        return v.heartbeat_timeout
    scaled = round(v.heartbeat_timeout * rate, 1)
    log(f"onboard guard: link timeout {scaled:g} s of vehicle time ({v.heartbeat_timeout:g} s of wall time; the "
        f"vehicle's clock runs {rate:.1f}x)")
    return scaled


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
