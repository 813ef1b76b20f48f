"""Whether the wind an autopilot streams is an estimate at all.

ArduCopter streams ``WIND`` whatever its EKF3 does, but the EKF3 learns its wind states only with drag fusion
(``EK3_DRAG_BCOEF_X`` and ``EK3_DRAG_BCOEF_Y`` > 0, or ``EK3_DRAG_MCOEF`` > 0) or an airspeed sensor in use
(``ARSPD_TYPE`` != 0 and ``ARSPD_USE`` 1); without either the wind states stay inhibited and ``WIND`` reads 0
whatever blows (measured on ArduCopter SITL with ``SIM_WIND_SPD`` 5). PX4's EKF2 learns wind from drag fusion
(``EKF2_DRAG_CTRL``), airspeed (``EKF2_ARSP_THR`` > 0) or sideslip fusion (``EKF2_FUSE_BETA``). A wind that is not
estimated is shown as "not estimated by the vehicle", never as its zero.
"""

from __future__ import annotations

import math
from collections.abc import Mapping


def wind_estimated(stack: str, params: Mapping[str, float]) -> bool | None:
    """True when the autopilot (``stack``: "ardupilot" or "px4") estimates the wind it streams, False when its
    parameters say it cannot, None when they do not tell (an unknown estimator, parameters missing)."""
    def on(name: str) -> bool:
        return float(params.get(name, 0.0) or 0.0) > 0

    if stack == "ardupilot":
        ekf = params.get("AHRS_EKF_TYPE")
        if ekf is None or int(ekf) not in (2, 3):
            return None  # SITL's true state (10) or an external AHRS: nothing to tell
        airspeed = params.get("ARSPD_TYPE", 0) not in (0, None) and on("ARSPD_USE")
        if int(ekf) == 2:
            return airspeed
        drag = (on("EK3_DRAG_BCOEF_X") and on("EK3_DRAG_BCOEF_Y")) or on("EK3_DRAG_MCOEF")
        return bool(drag or airspeed)
    if stack == "px4":
        if not any(n in params for n in ("EKF2_DRAG_CTRL", "EKF2_ARSP_THR", "EKF2_FUSE_BETA")):
            return None
        return on("EKF2_DRAG_CTRL") or on("EKF2_ARSP_THR") or on("EKF2_FUSE_BETA")
    return None


def wind_source_text(stack: str) -> str:
    """What would make the vehicle estimate its wind, for a note beside "not estimated"."""
    if stack == "ardupilot":
        return "EKF3 drag fusion off (EK3_DRAG_BCOEF_X/Y, EK3_DRAG_MCOEF 0) and no airspeed sensor"
    if stack == "px4":
        return "EKF2 drag, airspeed and sideslip fusion off"
    return "the autopilot does not estimate it"


def simulated_wind(params: Mapping[str, float], height_m: float) -> tuple[float, float, str] | None:
    """The wind a simulator blows at ``height_m`` above home, from its own parameters: (speed m/s, where it blows
    from in degrees, how that was read), or None for a vehicle that is no simulator we know.

    ArduPilot SITL: ``SIM_WIND_SPD`` from ``SIM_WIND_DIR`` (where it comes from), shaped by ``SIM_WIND_T``: 0 (the
    default) the square-root profile, ``SPD * sqrt(h / SIM_WIND_T_ALT)`` below ``SIM_WIND_T_ALT`` (60 m: at 10 m,
    41 % of the set speed); 1 the set speed at every height; 2 ``SPD + (h - T_ALT) * SIM_WIND_T_COEF``.
    ``SIM_WIND_TURB`` adds gusts around it. PX4 SIH (newer builds): ``SIH_WIND_N`` / ``SIH_WIND_E``, the vector
    the wind comes from (SIH flies ``v_apparent = v + wind``), the same at every height."""
    if "SIM_WIND_SPD" in params:
        spd, kind = float(params["SIM_WIND_SPD"]), int(params.get("SIM_WIND_T", 0))
        alt, coef = float(params.get("SIM_WIND_T_ALT", 60.0)), float(params.get("SIM_WIND_T_COEF", 0.01))
        turb = float(params.get("SIM_WIND_TURB", 0.0))
        if kind == 0 and height_m < alt:
            speed = spd * math.sqrt(max(height_m, 0.0) / alt)
            how = f"SIM_WIND_SPD {spd:g} m/s shaped by SIM_WIND_T 0, the square-root profile up to {alt:g} m"
        elif kind == 2:
            speed, how = max(0.0, spd + (height_m - alt) * coef), f"SIM_WIND_SPD {spd:g} m/s, SIM_WIND_T 2"
        else:
            speed, how = spd, f"SIM_WIND_SPD {spd:g} m/s" + (", SIM_WIND_T 1: the same at every height" if kind == 1
                                                             else "")
        gusts = f", gusts SIM_WIND_TURB {turb:g}" if turb > 0 else ""
        return speed, float(params.get("SIM_WIND_DIR", 0.0)) % 360.0, how + gusts
    if "SIH_WIND_N" in params and "SIH_WIND_E" in params:
        n, e = float(params["SIH_WIND_N"]), float(params["SIH_WIND_E"])
        return math.hypot(n, e), (math.degrees(math.atan2(e, n)) + 360.0) % 360.0, "SIH_WIND_N / SIH_WIND_E"
    return None
