"""How a campaign leaves the vehicle: baseline gains verified, then landed and disarmed or holding."""

from __future__ import annotations

from collections.abc import Callable

from ksbo_mav.errors import VehicleError
from ksbo_mav.mav.vehicle import Vehicle


def safe_stop(v: Vehicle, base: dict[str, float], where: str, log: Callable[[str], None]) -> None:
    """After Ctrl-C or an error between trials: make sure the baseline is on the vehicle (verified)."""
    if v.link.closed:
        return
    try:
        v.restore(base)
        log("stopped: baseline gains restored and verified")
    except (VehicleError, KeyboardInterrupt) as exc:
        log(f"stopped: baseline NOT verified ({exc}); run `ksbo-mav restore {where}`")


def end_flight(v: Vehicle, end: str, error: bool, log: Callable[[str], None]) -> str:
    """Leave the vehicle landed and disarmed (``end`` "land", and after any stop below the mission altitude), or
    holding where it is (``end`` "hold"): confirmed by the heartbeat, or said why not. Returns what was done:
    "landed", "holding", "unknown" (could not tell) or "" (it was not flying)."""
    if v.link.closed or not v.armed:
        return ""
    g = v.guided
    low = not g.height() >= 0.9 * float(v.mission.center_up)
    try:
        if end == "land" or (error and low):
            log("landing" + (" (stopped below the mission altitude)" if end != "land" else ""))
            g.land()
            log("landed and disarmed (confirmed by the heartbeat)")
            return "landed"
        here = g.position()
        if here is not None:
            g.hold_at(here)
        if v.stack.needs_stream:
            g.park()
        g.hold_at(None)
        log(f"holding at {g.height():.1f} m in {v.stack.mode_name(g.heartbeat.custom_mode)} (--end hold)")
        return "holding"
    except (VehicleError, KeyboardInterrupt) as exc:
        log(f"could not land/hold the vehicle: {exc}; it is now under its own failsafes - take over")
        return "unknown"
