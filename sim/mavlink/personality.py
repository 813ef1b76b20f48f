"""Autopilot identities the endpoint can wear: HEARTBEAT autopilot type, custom modes, param encoding.

The endpoint flies internal modes (:class:`Mode`); a :class:`Personality` maps them to and from the custom_mode
numbers a ground station expects. ``OURS`` is the built-in simulator's own identity (MAV_AUTOPILOT_GENERIC,
ArduCopter-compatible mode numbers, C-cast parameter encoding, vendor id 0x4B53 "KS"); ``ARDUPILOT`` and ``PX4``
let a vehicle model (e.g. the JSBSim copter) pose as those stacks. Add a personality by adding an instance to
``PERSONALITIES``; nothing else in the endpoint knows stack-specific numbers.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

# MAV_PROTOCOL_CAPABILITY bits (fact sheet 1.1).
CAP_MISSION_INT = 4
CAP_COMMAND_INT = 8
CAP_PARAM_ENCODE_BYTEWISE = 16
CAP_FTP = 32
CAP_SET_POSITION_TARGET_LOCAL_NED = 128
CAP_MAVLINK2 = 8192
CAP_PARAM_ENCODE_C_CAST = 131072

MAV_AUTOPILOT_GENERIC = 0
MAV_AUTOPILOT_ARDUPILOTMEGA = 3
MAV_AUTOPILOT_PX4 = 12

#: AUTOPILOT_VERSION.vendor_id of the built-in simulator ("KS"); product_id = 1 planar, 2 copter3d.
KSBO_VENDOR_ID = 0x4B53


class Mode(enum.Enum):
    """What the vehicle does, independent of any stack's numbering."""

    MANUAL = "manual"  # boot mode; without RC it holds position when airborne
    GUIDED = "guided"  # follows SET_POSITION_TARGET_LOCAL_NED (ArduPilot GUIDED, PX4 OFFBOARD)
    HOLD = "hold"  # holds the position where the mode was entered (LOITER, POSCTL, AUTO.LOITER)
    LAND = "land"  # descends and disarms on touchdown
    TAKEOFF = "takeoff"  # PX4 AUTO.TAKEOFF only; ArduPilot takes off inside GUIDED
    RTL = "rtl"  # returns home at the current height and lands there (a failsafe's action)
    AUTO = "auto"  # flies the stored mission's waypoints (ArduPilot AUTO, PX4 AUTO.MISSION): ksbo_sim.mavlink.auto_nav


@dataclass(frozen=True)
class Personality:
    name: str
    autopilot: int
    #: custom_mode -> Mode (first entry per Mode is the one reported).
    modes: dict[int, Mode]
    mode_names: dict[int, str]
    encoding: str  # "c_cast" or "bytewise" for INT32 parameters
    #: ArduPilot answers PARAM_SET with param_index 65535; PX4 and ours with the real index.
    echo_index: bool = True
    #: DO_SET_MODE: ArduPilot p2 = custom_mode; PX4 p2 = main mode, p3 = sub mode.
    px4_mode_params: bool = False
    #: Mode reported while NAV_TAKEOFF climbs, and the mode after it (None = stay in the current mode).
    takeoff_mode: Mode | None = None
    after_takeoff_mode: Mode | None = None
    vendor_id: int = KSBO_VENDOR_ID
    flight_sw_version: int = (0 << 24) | (1 << 16) | (0 << 8) | 255
    custom_version: bytes = b"ksbosim\0"
    extra_caps: int = 0
    #: The stored mission keeps home as item 0 and flies from item 1 (ArduPilot); PX4 flies from item 0.
    mission_home_item: bool = True
    #: Seconds after an upload while the mission is being checked: AUTO is "temporarily rejected" (PX4).
    mission_check_s: float = 0.0
    #: The parameter naming the ground station's system id (ArduPilot 4.7 MAV_GCS_SYSID; 4.5/4.6 SYSID_MYGCS).
    gcs_sysid_param: str = "MAV_GCS_SYSID"

    @property
    def capabilities(self) -> int:
        enc = CAP_PARAM_ENCODE_BYTEWISE if self.encoding == "bytewise" else CAP_PARAM_ENCODE_C_CAST
        caps = CAP_MAVLINK2 | CAP_SET_POSITION_TARGET_LOCAL_NED | self.extra_caps
        # ArduPilot sets neither encoding bit (fact sheet 1.1); everyone else declares theirs.
        return caps if self.autopilot == MAV_AUTOPILOT_ARDUPILOTMEGA else caps | enc

    def custom_mode(self, mode: Mode) -> int:
        for number, m in self.modes.items():
            if m is mode:
                return number
        raise KeyError(mode)

    def decode_mode(self, custom_mode: int) -> Mode | None:
        return self.modes.get(int(custom_mode))

    def mode_from_command(self, p2: float, p3: float) -> Mode | None:
        """DO_SET_MODE params -> Mode (None if this personality has no such mode)."""
        if self.px4_mode_params:
            return self.decode_mode((int(p2) << 16) | (int(p3) << 24))
        return self.decode_mode(int(p2))


_COPTER_MODES = {0: Mode.MANUAL, 3: Mode.AUTO, 4: Mode.GUIDED, 5: Mode.HOLD, 6: Mode.RTL, 9: Mode.LAND, 16: Mode.HOLD,
                 17: Mode.HOLD}
_COPTER_NAMES = {0: "STABILIZE", 3: "AUTO", 4: "GUIDED", 5: "LOITER", 6: "RTL", 9: "LAND", 16: "POSHOLD", 17: "BRAKE"}

OURS = Personality(name="ours", autopilot=MAV_AUTOPILOT_GENERIC, modes=_COPTER_MODES, mode_names=_COPTER_NAMES,
                   encoding="c_cast")

#: ArduCopter 4.7 (PSC_NE_* names, MAV_GCS_SYSID): AUTOPILOT_VERSION says 4.7.0 official.
ARDUPILOT = Personality(name="ardupilot", autopilot=MAV_AUTOPILOT_ARDUPILOTMEGA, modes=_COPTER_MODES,
                        mode_names=_COPTER_NAMES, encoding="c_cast", echo_index=False, vendor_id=0,
                        flight_sw_version=(4 << 24) | (7 << 16) | (0 << 8) | 255, custom_version=b"ksbosim\0")
#: The generation before it, as ArduCopter 4.5 and 4.6 are (PSC_POSXY_* names, SYSID_MYGCS): 4.6.0 official.
ARDUPILOT_LEGACY = Personality(name="ardupilot-legacy", autopilot=MAV_AUTOPILOT_ARDUPILOTMEGA, modes=_COPTER_MODES,
                               mode_names=_COPTER_NAMES, encoding="c_cast", echo_index=False, vendor_id=0,
                               flight_sw_version=(4 << 24) | (6 << 16) | (0 << 8) | 255,
                               custom_version=b"ksbosim\0", gcs_sysid_param="SYSID_MYGCS")

_PX4_MODES = {393216: Mode.GUIDED, 50593792: Mode.HOLD, 196608: Mode.HOLD, 100925440: Mode.LAND,
              33816576: Mode.TAKEOFF, 84148224: Mode.RTL, 65536: Mode.MANUAL, 131072: Mode.MANUAL,
              67371008: Mode.AUTO}
_PX4_NAMES = {393216: "OFFBOARD", 50593792: "AUTO.LOITER", 196608: "POSCTL", 100925440: "AUTO.LAND",
              33816576: "AUTO.TAKEOFF", 84148224: "AUTO.RTL", 131072: "ALTCTL", 65536: "MANUAL",
              67371008: "AUTO.MISSION"}

PX4 = Personality(name="px4", autopilot=MAV_AUTOPILOT_PX4, modes=_PX4_MODES, mode_names=_PX4_NAMES,
                  encoding="bytewise", px4_mode_params=True, takeoff_mode=Mode.TAKEOFF,
                  after_takeoff_mode=Mode.HOLD, vendor_id=0, flight_sw_version=(1 << 24) | (15 << 16) | 255,
                  mission_home_item=False, mission_check_s=1.0)

#: CLI --personality values; ardupilot-legacy differs from ardupilot in the model's parameter names, the firmware
#: version it reports and the name of the ground station's system id parameter.
PERSONALITIES: dict[str, Personality] = {"ours": OURS, "ardupilot": ARDUPILOT, "ardupilot-legacy": ARDUPILOT_LEGACY,
                                         "px4": PX4}
