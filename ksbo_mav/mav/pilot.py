"""Whose the vehicle is: the modes ksbo-mav puts it in, and how a pilot's take-over looks from the tool.

ksbo-mav flies in the stack's guided mode (ArduPilot GUIDED, PX4 OFFBOARD) and, on PX4 only, parks the vehicle in
AUTO.LOITER between trials (OFFBOARD fails safe when the setpoint stream stops). Any other mode — the pilot's
LOITER, POSHOLD or Position, a ground station's choice, the autopilot's own RTL or LAND — is somebody else's: the
tool never switches the vehicle out of it.
"""

from __future__ import annotations

from typing import Any

from ksbo_mav.mav.stacks import Stack


def tool_modes(stack: Stack) -> set[int]:
    """The custom modes ksbo-mav leaves the vehicle in."""
    return {stack.modes["guided"]} | ({stack.modes["hold"]} if stack.needs_stream else set())


def taken_over(stack: Stack, hb: Any) -> str | None:
    """Why a vehicle that was ours is not any more (``hb``: its latest HEARTBEAT), or None while it is."""
    if not hb.base_mode & 128:
        return "the vehicle was disarmed between trials (the pilot or a ground station): ksbo-mav does not take off " \
               "again"
    if int(hb.custom_mode) not in tool_modes(stack):
        return f"the vehicle was switched to {stack.mode_name(hb.custom_mode)} between trials (the pilot or a " \
               "ground station): ksbo-mav leaves it there"
    return None
