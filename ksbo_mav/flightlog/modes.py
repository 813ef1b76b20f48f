"""Flight-mode tables of the logs: which modes track position targets (guided/auto/offboard)."""

# ArduCopter modes (fact sheet 1.3 plus the rest of Copter's table); position-target tracking ones flagged.
COPTER_MODES = {0: "STABILIZE", 1: "ACRO", 2: "ALT_HOLD", 3: "AUTO", 4: "GUIDED", 5: "LOITER", 6: "RTL",
                7: "CIRCLE", 9: "LAND", 11: "DRIFT", 13: "SPORT", 14: "FLIP", 15: "AUTOTUNE", 16: "POSHOLD",
                17: "BRAKE", 18: "THROW", 19: "AVOID_ADSB", 20: "GUIDED_NOGPS", 21: "SMART_RTL", 22: "FLOWHOLD",
                23: "FOLLOW", 24: "ZIGZAG", 25: "SYSTEMID", 26: "AUTOROTATE", 27: "AUTO_RTL", 28: "TURTLE"}
COPTER_TRACKING = {3, 4}  # AUTO, GUIDED
# PX4 vehicle_status.nav_state
PX4_NAV = {0: "MANUAL", 1: "ALTCTL", 2: "POSCTL", 3: "AUTO_MISSION", 4: "AUTO_LOITER", 5: "AUTO_RTL",
           6: "POSITION_SLOW", 10: "ACRO", 12: "DESCEND", 13: "TERMINATION", 14: "OFFBOARD", 15: "STAB",
           17: "AUTO_TAKEOFF", 18: "AUTO_LAND", 19: "AUTO_FOLLOW_TARGET", 20: "AUTO_PRECLAND", 21: "ORBIT",
           22: "AUTO_VTOL_TAKEOFF"}
PX4_TRACKING = {3, 14}  # AUTO_MISSION, OFFBOARD
# PX4 custom_mode main modes in HEARTBEAT (fact sheet 1.3): 4 AUTO (sub 4 MISSION), 6 OFFBOARD
PX4_MAIN = {1: "MANUAL", 2: "ALTCTL", 3: "POSCTL", 4: "AUTO", 5: "ACRO", 6: "OFFBOARD", 7: "STABILIZED", 8: "RATTITUDE"}
PX4_AUTO_SUB = {1: "READY", 2: "TAKEOFF", 3: "LOITER", 4: "MISSION", 5: "RTL", 6: "LAND", 8: "FOLLOW_TARGET",
                9: "PRECLAND"}
# Other ArduPilot vehicles (custom_mode / MODE ModeNum); AUTO and GUIDED track position targets.
PLANE_MODES = {0: "MANUAL", 1: "CIRCLE", 2: "STABILIZE", 3: "TRAINING", 4: "ACRO", 5: "FLY_BY_WIRE_A",
               6: "FLY_BY_WIRE_B", 7: "CRUISE", 8: "AUTOTUNE", 10: "AUTO", 11: "RTL", 12: "LOITER", 13: "TAKEOFF",
               14: "AVOID_ADSB", 15: "GUIDED", 17: "QSTABILIZE", 18: "QHOVER", 19: "QLOITER", 20: "QLAND",
               21: "QRTL", 22: "QAUTOTUNE", 23: "QACRO", 24: "THERMAL", 25: "LOITER_ALT_QLAND"}
ROVER_MODES = {0: "MANUAL", 1: "ACRO", 3: "STEERING", 4: "HOLD", 5: "LOITER", 6: "FOLLOW", 7: "SIMPLE",
               8: "DOCK", 9: "CIRCLE", 10: "AUTO", 11: "RTL", 12: "SMART_RTL", 15: "GUIDED"}
SUB_MODES = {0: "STABILIZE", 1: "ACRO", 2: "ALT_HOLD", 3: "AUTO", 4: "GUIDED", 7: "CIRCLE", 9: "SURFACE",
             16: "POSHOLD", 19: "MANUAL", 20: "MOTOR_DETECT"}
VEHICLE_MODES = {"copter": (COPTER_MODES, COPTER_TRACKING), "plane": (PLANE_MODES, {10, 15}),
                 "rover": (ROVER_MODES, {10, 15}), "sub": (SUB_MODES, {3, 4})}


def vehicle_from_type(mav_type: int) -> str:
    """ArduPilot vehicle from HEARTBEAT.type (MAV_TYPE)."""
    if mav_type in (1, 16, 19, 20, 21, 22, 23, 24, 25):
        return "plane"
    return {10: "rover", 11: "rover", 12: "sub"}.get(mav_type, "copter")


def vehicle_from_text(text: str) -> str | None:
    """ArduPilot vehicle from a firmware banner ("ArduPlane V4.5.7", "APM:Copter V3.4.6")."""
    for key, name in (("Plane", "plane"), ("Rover", "rover"), ("Sub", "sub"), ("Copter", "copter")):
        if f"Ardu{key}" in text or f"APM:{key}" in text or text.startswith(f"{key} V"):
            return name
    return None


def ardupilot_mode(vehicle: str, num: int) -> tuple[str, bool]:
    """(name, tracks position targets) of an ArduPilot mode number on that vehicle."""
    names, tracking = VEHICLE_MODES.get(vehicle, VEHICLE_MODES["copter"])
    return names.get(num, f"MODE{num}"), num in tracking
