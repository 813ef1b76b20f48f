"""Arming, takeoff to the mission's start and landing, on a :class:`~ksbo_mav.mav.guided.Guided` vehicle.

The stacks differ here as the guided module says: ArduCopter takes off by MAV_CMD_NAV_TAKEOFF in GUIDED; PX4
streams a position target above itself in OFFBOARD and arms into it (retrying while its preflight checks run).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ksbo_mav.errors import PreflightError, VehicleError
from ksbo_mav.mav.commands import CMD_ARM, CMD_TAKEOFF, refusal
from ksbo_mav.mav.guided import Guided


def arm(g: Guided, timeout_s: float = 90.0, log: Callable[[str], None] = lambda s: None) -> None:
    """Arm, retrying while the vehicle says "temporarily rejected" / "failed" (preflight checks still running,
    no position estimate yet), within ``timeout_s`` of vehicle time; the vehicle's reason on one line."""
    last = known = ""
    start = g.tel.clock.last_ms if g.tel.clock.valid else None
    while True:
        result, reason = g.cmd.attempt(CMD_ARM, 1.0)
        if result == 0:
            if g.wait(3.0, lambda: g.armed):
                return
            last = "accepted, but the heartbeat never showed the vehicle armed"
        elif result in (1, 4):
            # Autopilots rate-limit repeated pre-arm messages: a refusal without text keeps the last reason.
            reason = reason or known
            known = reason
            if refusal("arming", result, reason) != last:
                log(f"{refusal('arming', result, reason)}; retrying for up to {timeout_s:g} s")
            last = refusal("arming", result, reason)
        else:
            raise PreflightError(refusal("arming", result, reason))
        now = g.tel.clock.last_ms if g.tel.clock.valid else None
        if start is not None and now is not None and now - start > timeout_s * 1000:
            raise PreflightError(f"vehicle did not arm within {timeout_s:g} s: {last}")
        g.wait(1.0)


def ensure_airborne(g: Guided, alt: float, start: np.ndarray, tol: float, settle_s: float = 2.0,
                    log: Callable[[str], None] = lambda s: None,
                    check: Callable[[Any], None] = lambda hb: None) -> None:
    """Armed in guided/offboard, hovering at ``start`` (NED; within ``tol`` m, then ``settle_s`` s of vehicle time
    there), taking off if needed; an armed vehicle in a mode neither guided nor hold is refused: PreflightError
    (never the gains' fault). ``check(hb)`` may refuse first and, on the newest heartbeat, before guided."""
    hb = g.link.wait_heartbeat(g.heartbeat_timeout)
    check(hb)
    mine = (g.stack.modes["guided"], g.stack.modes["hold"])
    if hb.base_mode & 128 and int(hb.custom_mode) not in mine:
        raise PreflightError(f"vehicle is armed in mode {g.stack.mode_name(hb.custom_mode)}; switch it to "
                             f"{g.stack.mode_name(mine[0])} (or land it) before tuning")
    if not hb.base_mode & 128:
        takeoff(g, alt, log)
    g.hold_at(start)
    if not g.in_mode("guided"):
        check(g.heartbeat)
        g.enter("guided")
    if not g.wait(60.0, lambda: g.near(start, tol) or not g.in_mode("guided")):
        raise PreflightError(f"the vehicle did not come within {tol:g} m of the figure-8 start in 60 s "
                             f"(at {np.round(g.position(), 2)})")
    if not g.in_mode("guided"):  # (PX4 leaves OFFBOARD for its failsafe when the setpoint stream pauses)
        check(g.heartbeat)
        raise PreflightError(f"the vehicle left {g.stack.mode_name(g.stack.modes['guided'])} for "
                             f"{g.stack.mode_name(g.heartbeat.custom_mode)} on its way to the figure-8 start (the "
                             "autopilot's failsafe, the pilot or a ground station): ksbo-mav leaves it there")
    g.wait(settle_s)


def takeoff(g: Guided, alt: float, log: Callable[[str], None]) -> None:
    log(f"arming and taking off to {alt:g} m")
    if not g.wait(120.0, lambda: g.tel.last_lpn is not None):
        raise PreflightError("no position estimate (LOCAL_POSITION_NED) after 120 s: GPS / EKF not ready")
    here = g.position()
    assert here is not None
    if g.stack.needs_stream:  # PX4: a position target above the vehicle, in OFFBOARD, then arm
        g.hold_at(np.array([here[0], here[1], -alt]))
        g.enter("guided")
        arm(g, log=log)
    else:
        g.hold_at(None)
        g.enter("guided")
        arm(g, log=log)
        result, reason = g.cmd.attempt(CMD_TAKEOFF, 0, 0, 0, float("nan"), float("nan"), float("nan"), alt)
        if result != 0:
            raise PreflightError(refusal("takeoff", result, reason))
    if not g.wait(30.0 + 4.0 * alt, lambda: g.height() > 0.9 * alt):
        raise PreflightError(f"takeoff did not reach {0.9 * alt:.1f} m (at {g.height():.2f} m)")


def land(g: Guided, timeout_s: float = 120.0) -> None:
    """LAND, then wait on the vehicle clock until the heartbeat shows it disarmed; VehicleError otherwise."""
    if not g.armed:
        return
    g.hold_at(None)
    g.cmd.set_mode("land")
    if not g.wait(timeout_s, lambda: not g.armed):
        raise VehicleError(f"the vehicle did not land and disarm within {timeout_s:g} s of vehicle time "
                           f"(height {g.height():.2f} m)")
