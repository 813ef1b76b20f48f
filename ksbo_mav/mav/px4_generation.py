"""PX4's parameter generations as the tuner meets them, told apart by the parameter list (never by a version number
alone: a 1.19.0-dev may be from before or after a change).

What the tuner reads on PX4 and where it moved (checked against the parameter metadata each SITL build ships,
``etc/extras/parameters.json.xz``, v1.15.4 and main of 2026-08-13; docs/firmware.md):

* the six tuned ``MPC_*`` gains, ``MPC_TILTMAX_AIR`` and the link-loss failsafes (``COM_OF_LOSS_T``,
  ``COM_OBL_RC_ACT``, ``NAV_DLL_ACT``, ``COM_DL_LOSS_T``): same names, defaults and ranges in both; only the
  label of ``COM_OBL_RC_ACT`` 2 changed ("Manual" -> "Stabilized");
* how a pilot's sticks take OFFBOARD back: up to 1.17 ``COM_RC_OVERRIDE`` bit 1 with the deflection threshold
  ``COM_RC_STICK_OV`` (%); from 1.18 ``MAN_OVERRIDE_SPD`` (stick travel per second, negative: off), for every mode;
* 1.17 removed ``MPC_*_MAN_EXPO`` and renamed ``MPC_HOLD_DZ`` to ``MAN_DEADZONE``; 1.18 removed
  ``COM_OBC_LOSS_T`` and ``MPC_LAND_RC_HELP``. The tuner reads none of these: they only tell the generation.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

#: (label, the parameter that marks it): newest first. The first whose marker is present names the generation.
GENERATIONS = (
    ("1.18+ (MAN_OVERRIDE_SPD, no COM_RC_OVERRIDE)", "MAN_OVERRIDE_SPD"),
    ("1.17 (MAN_DEADZONE, COM_RC_OVERRIDE)", "MAN_DEADZONE"),
    ("<= 1.16 (MPC_HOLD_DZ, COM_RC_OVERRIDE)", "MPC_HOLD_DZ"),
)


def px4_generation(names: Mapping[str, Any] | set[str]) -> str:
    """The parameter generation of a PX4 vehicle from its parameter list ("" when no marker is there)."""
    return next((label for label, marker in GENERATIONS if marker in names), "")


def offboard_loss_mode_2(names: Mapping[str, Any] | set[str]) -> str:
    """The name of ``COM_OBL_RC_ACT`` 2, which PX4 renamed with the stick-override change."""
    return "Stabilized mode" if "MAN_OVERRIDE_SPD" in names else "Manual mode"


def stick_override_words(values: Mapping[str, float]) -> str:
    """How the pilot's sticks take the vehicle out of OFFBOARD on this generation ({name: value} of its
    parameters); "" when neither setting is there."""
    if "MAN_OVERRIDE_SPD" in values:
        speed = float(values["MAN_OVERRIDE_SPD"])
        if speed < 0:
            return "stick override is off (MAN_OVERRIDE_SPD < 0): the pilot takes over by switching modes"
        return (f"moving a stick faster than {speed:g} stick travel/s (MAN_OVERRIDE_SPD) switches to Position mode "
                "and ends the trial")
    if "COM_RC_OVERRIDE" in values:
        bits = int(values["COM_RC_OVERRIDE"])
        if not bits & 2:
            return ("stick override of OFFBOARD is off (COM_RC_OVERRIDE bit 1 clear): the pilot takes over by "
                    "switching modes")
        threshold = values.get("COM_RC_STICK_OV")
        more = f" more than {float(threshold):g} %" if threshold is not None else ""
        return (f"moving a stick{more} (COM_RC_OVERRIDE bit 1, COM_RC_STICK_OV) switches to Position mode and ends "
                "the trial")
    return ""


#: PX4 serves ``@PARAM/param.pck`` over MAVLink FTP from PR #28435 (merged after its main of 2026-08-13, so from
#: the 1.19 series on); every release before it answers "file not found". A 1.19.0-dev may be either: it is asked.
PARAM_FILE_FROM = (1, 19)


def serves_param_file(stack: str, flight_sw_version: int) -> bool:
    """Whether asking this vehicle for ``@PARAM/param.pck`` can succeed (False only for PX4 before 1.19)."""
    v = int(flight_sw_version)
    return stack != "px4" or (v >> 24 & 0xFF, v >> 16 & 0xFF) >= PARAM_FILE_FROM
