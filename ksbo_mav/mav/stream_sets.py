"""The messages each autopilot streams on a MAVLink port of its own accord or when a ground station asks for its
stream groups: a table per stack, so the streams that fill a thin link can be asked down without first seeing
them arrive (on a radio losing 90 % of the frames, a 4 Hz stream may not show up in a 3 s measurement at all).

* ArduPilot: the message sets of the ``MAVn_*`` stream groups a ground station sets with REQUEST_DATA_STREAM
  (``libraries/GCS_MAVLink/GCS_MAVLink_Parameters.cpp`` of ArduPilot 4.7, ``all_stream_entries``; ap_message
  names mapped to their MAVLink messages, e.g. ``MSG_LOCATION`` is GLOBAL_POSITION_INT, ``MSG_CURRENT_WAYPOINT``
  MISSION_CURRENT, ``MSG_NEXT_PARAM`` PARAM_VALUE).
* PX4: the streams its mavlink module configures for a port by the port's mode
  (``src/modules/mavlink/mavlink_main.cpp``, ``configure_streams_to_default``, v1.15: Normal, Onboard,
  OnboardLowBandwidth, ExtVision, OSD, Config, Minimal; a radio port runs Normal, a companion port Onboard; the
  union is taken, as which mode the port runs is not visible over MAVLink).
* ksbo-mav's simulator: its default streams.

A message a firmware does not have is refused (COMMAND_ACK) or ignored: asking costs one command on the uplink.
"""

from __future__ import annotations

from ksbo_mav.mav.wire import mavlink

ARDUPILOT_GROUPS: dict[str, tuple[str, ...]] = {
    "RAW_SENS": ("RAW_IMU", "SCALED_IMU2", "SCALED_IMU3", "SCALED_PRESSURE", "SCALED_PRESSURE2", "SCALED_PRESSURE3",
                 "AIRSPEED"),
    "EXT_STAT": ("SYS_STATUS", "POWER_STATUS", "MCU_STATUS", "MEMINFO", "MISSION_CURRENT", "GPS_RAW_INT", "GPS_RTK",
                 "GPS2_RAW", "GPS2_RTK", "NAV_CONTROLLER_OUTPUT", "FENCE_STATUS", "POSITION_TARGET_GLOBAL_INT"),
    "POSITION": ("GLOBAL_POSITION_INT", "LOCAL_POSITION_NED"),
    "RC_CHAN": ("SERVO_OUTPUT_RAW", "RC_CHANNELS", "RC_CHANNELS_RAW"),
    "EXTRA1": ("ATTITUDE", "SIMSTATE", "AHRS2", "RPM", "PID_TUNING", "ESC_TELEMETRY_1_TO_4", "GENERATOR_STATUS",
               "WINCH_STATUS", "EFI_STATUS", "HYGROMETER_SENSOR"),
    "EXTRA2": ("VFR_HUD",),
    "EXTRA3": ("AHRS", "WIND", "DISTANCE_SENSOR", "SYSTEM_TIME", "TERRAIN_REPORT", "TERRAIN_REQUEST", "BATTERY_STATUS",
               "GIMBAL_DEVICE_ATTITUDE_STATUS", "OPTICAL_FLOW", "MAG_CAL_REPORT", "MAG_CAL_PROGRESS",
               "EKF_STATUS_REPORT", "VIBRATION"),
    "PARAMS": ("PARAM_VALUE", "AVAILABLE_MODES"),
    "ADSB": ("ADSB_VEHICLE", "AIS_VESSEL"),
}

#: PX4 1.15's default streams, by port mode (stream names given as their messages: SERVO_OUTPUT_RAW_0 and _1 are
#: SERVO_OUTPUT_RAW, ACTUATOR_CONTROL_TARGET0 is ACTUATOR_CONTROL_TARGET).
PX4_MODES: dict[str, tuple[str, ...]] = {
    "Normal": ("ADSB_VEHICLE", "ALTITUDE", "ATTITUDE", "ATTITUDE_TARGET", "BATTERY_STATUS", "CAMERA_IMAGE_CAPTURED",
               "COLLISION", "DISTANCE_SENSOR", "EFI_STATUS", "ESC_INFO", "ESC_STATUS", "ESTIMATOR_STATUS",
               "EXTENDED_SYS_STATE", "GLOBAL_POSITION_INT", "GIMBAL_DEVICE_ATTITUDE_STATUS", "GIMBAL_MANAGER_STATUS",
               "GIMBAL_DEVICE_SET_ATTITUDE", "GPS2_RAW", "GPS_GLOBAL_ORIGIN", "GPS_RAW_INT", "GPS_STATUS",
               "HOME_POSITION", "LOCAL_POSITION_NED", "NAV_CONTROLLER_OUTPUT", "OBSTACLE_DISTANCE",
               "ORBIT_EXECUTION_STATUS", "PING", "POSITION_TARGET_GLOBAL_INT", "POSITION_TARGET_LOCAL_NED", "RAW_RPM",
               "RC_CHANNELS", "SERVO_OUTPUT_RAW", "SYS_STATUS", "UTM_GLOBAL_POSITION", "VFR_HUD", "VIBRATION",
               "WIND_COV", "DEBUG", "DEBUG_FLOAT_ARRAY", "DEBUG_VECT", "NAMED_VALUE_FLOAT", "LINK_NODE_STATUS"),
    "Onboard": ("TIMESYNC", "CAMERA_TRIGGER", "HIGHRES_IMU", "LOCAL_POSITION_NED", "ATTITUDE", "ALTITUDE",
                "DISTANCE_SENSOR", "ESC_INFO", "ESC_STATUS", "MOUNT_ORIENTATION", "OBSTACLE_DISTANCE", "ODOMETRY",
                "ACTUATOR_CONTROL_TARGET", "ADSB_VEHICLE", "ATTITUDE_QUATERNION", "ATTITUDE_TARGET",
                "BATTERY_STATUS", "CAMERA_IMAGE_CAPTURED", "COLLISION", "EFI_STATUS", "ESTIMATOR_STATUS",
                "EXTENDED_SYS_STATE", "GIMBAL_DEVICE_ATTITUDE_STATUS", "GIMBAL_MANAGER_STATUS",
                "GIMBAL_DEVICE_SET_ATTITUDE", "GLOBAL_POSITION_INT", "GPS2_RAW", "GPS_GLOBAL_ORIGIN", "GPS_RAW_INT",
                "GPS_STATUS", "HOME_POSITION", "NAV_CONTROLLER_OUTPUT", "OPTICAL_FLOW_RAD", "ORBIT_EXECUTION_STATUS",
                "PING", "POSITION_TARGET_GLOBAL_INT", "POSITION_TARGET_LOCAL_NED", "RAW_RPM", "RC_CHANNELS",
                "SERVO_OUTPUT_RAW", "SYS_STATUS", "SYSTEM_TIME", "TRAJECTORY_REPRESENTATION_WAYPOINTS",
                "UTM_GLOBAL_POSITION", "VFR_HUD", "VIBRATION", "WIND_COV", "DEBUG", "DEBUG_FLOAT_ARRAY", "DEBUG_VECT",
                "NAMED_VALUE_FLOAT", "LINK_NODE_STATUS"),
    "Config": ("SCALED_IMU", "SCALED_IMU2", "SCALED_IMU3", "MANUAL_CONTROL"),  # besides Onboard's
    "Minimal/OSD/ExtVision": (),  # subsets of the above
}

#: Our simulator's default streams (``ksbo_sim.mavlink.telemetry``; BATTERY_STATUS and WIND with a pack and wind).
SIMULATOR_STREAMS = ("SYS_STATUS", "SYSTEM_TIME", "ATTITUDE", "LOCAL_POSITION_NED", "SERVO_OUTPUT_RAW",
                     "ACTUATOR_OUTPUT_STATUS", "BATTERY_STATUS", "WIND")

#: Messages of the tables that the dialect bundled with pymavlink does not define (MAVLink common/development ids).
_IDS_NOT_IN_DIALECT = {"AVAILABLE_MODES": 435, "ESC_INFO": 290, "ESC_STATUS": 291, "LINK_NODE_STATUS": 8}


def default_streams(stack_name: str) -> dict[str, tuple[str, ...]]:
    """{group (ArduPilot) or port mode (PX4): message names} for a stack (``Stack.name``); the simulator's for
    anything else."""
    if stack_name == "ardupilot":
        return ARDUPILOT_GROUPS
    if stack_name == "px4":
        return PX4_MODES
    return {"default": SIMULATOR_STREAMS}


def message_id(name: str) -> int | None:
    """The MAVLink message id of ``name`` (None: unknown)."""
    return getattr(mavlink, f"MAVLINK_MSG_ID_{name}", _IDS_NOT_IN_DIALECT.get(name))


def group_of(stack_name: str, name: str) -> str | None:
    """The stream group (ArduPilot) or port mode (PX4) that lists ``name`` first, or None."""
    return next((g for g, names in default_streams(stack_name).items() if name in names), None)


def all_messages(stack_name: str) -> list[str]:
    """Every message of the stack's table, each once, in table order."""
    return list(dict.fromkeys(n for names in default_streams(stack_name).values() for n in names))
