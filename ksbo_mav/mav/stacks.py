"""Autopilot stacks as the tuner sees them: identity, mode numbers, INT32 encoding, parameter name generations.

The vehicle says which stack it runs (HEARTBEAT.autopilot, AUTOPILOT_VERSION vendor/product); the parameter list
says which *name generation* of that stack (ArduPilot renamed and rescaled ``PSC_*`` in PR #31513, fact sheet
3.1). Profiles name their gains in the newest generation and SI units; :class:`GainMap` translates a gain vector
to the parameters of the vehicle at hand (``parameter value = gain value / scale``) and back, so every stack
and generation maps to the *same* gain vector. Anything unknown is refused rather than guessed.
"""

from __future__ import annotations

import fnmatch
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ksbo_mav.errors import InputError, VehicleError
from ksbo_mav.profiles import Profile

MAV_AUTOPILOT_GENERIC, MAV_AUTOPILOT_ARDUPILOTMEGA, MAV_AUTOPILOT_PX4 = 0, 3, 12
KSBO_VENDOR_ID = 0x4B53  # "KS": the built-in simulator (AUTOPILOT_VERSION.vendor_id)
KSBO_PRODUCT_PLANAR, KSBO_PRODUCT_COPTER3D = 1, 2


@dataclass(frozen=True)
class Stack:
    """Stack-specific numbers the client needs."""

    name: str  # "ksbo-sim", "ardupilot", "px4"
    autopilot: int
    encoding: str  # INT32 parameter encoding: "c_cast" or "bytewise"
    modes: Mapping[str, int]  # "guided" / "hold" / "land" -> custom_mode
    mode_names: Mapping[int, str]
    px4_mode_params: bool = False  # DO_SET_MODE p2 = main mode, p3 = sub mode (PX4)
    #: guided mode needs a running setpoint stream (PX4 OFFBOARD): stream before entering, park when stopping
    needs_stream: bool = False
    #: holds a position setpoint as sent until the next one arrives (PX4 OFFBOARD); ArduPilot's guided mode instead
    #: carries it forward with the velocity and acceleration sent beside it
    holds_setpoints: bool = False
    #: answers PARAM_REQUEST_READ("_HASH_CHECK") with a hash of its parameter set (PX4): a cached set is reusable
    param_hash: bool = False

    def mode_name(self, custom_mode: int) -> str:
        return self.mode_names.get(int(custom_mode), str(custom_mode))

    def mode_params(self, custom_mode: int) -> tuple[float, float, float]:
        """DO_SET_MODE (p1, p2, p3) for a custom mode."""
        if self.px4_mode_params:
            return 1.0, float((custom_mode >> 16) & 0xFF), float((custom_mode >> 24) & 0xFF)
        return 1.0, float(custom_mode), 0.0


_COPTER_NAMES = {0: "STABILIZE", 2: "ALT_HOLD", 3: "AUTO", 4: "GUIDED", 5: "LOITER", 6: "RTL", 9: "LAND",
                 16: "POSHOLD", 17: "BRAKE"}
ARDUPILOT = Stack("ardupilot", MAV_AUTOPILOT_ARDUPILOTMEGA, "c_cast", {"guided": 4, "hold": 5, "land": 9, "auto": 3},
                  _COPTER_NAMES)
#: The built-in simulator numbers its modes like ArduCopter but declares its own identity.
KSBO_SIM = Stack("ksbo-sim", MAV_AUTOPILOT_GENERIC, "c_cast", {"guided": 4, "hold": 5, "land": 9, "auto": 3},
                 _COPTER_NAMES)
_PX4_NAMES = {393216: "OFFBOARD", 50593792: "AUTO.LOITER", 196608: "POSCTL", 100925440: "AUTO.LAND",
              33816576: "AUTO.TAKEOFF", 131072: "ALTCTL", 65536: "MANUAL", 67371008: "AUTO.MISSION"}
PX4 = Stack("px4", MAV_AUTOPILOT_PX4, "bytewise",
            {"guided": 393216, "hold": 50593792, "land": 100925440, "auto": 67371008},
            _PX4_NAMES, px4_mode_params=True, needs_stream=True, holds_setpoints=True,
            param_hash=True)


#: Parameters the autopilot itself writes while it boots and flies (measured on ArduCopter 4.7.0-dev and PX4 1.15.4
#: SITL over a campaign from the ground): flight statistics, boot-time calibrations (baro ground pressure, the
#: declination looked up from the GPS position), the learned hover throttle, the home point stored as mission item 0,
#: per-flight ids. A campaign leaves every other parameter as its snapshot found it.
AUTOPILOT_UPDATED = {
    "ardupilot": ("STAT_BOOTCNT", "STAT_FLTTIME", "STAT_RUNTIME", "STAT_RESET", "MOT_THST_HOVER", "BARO1_GND_PRESS",
                  "BARO2_GND_PRESS", "BARO3_GND_PRESS", "COMPASS_DEC", "MIS_TOTAL"),
    # PX4 also saves the accelerometer biases it learns in flight (and re-ranks that sensor's priority); PX4 main
    # clears the fusion bit of a second GNSS it does not have (EKF2_SENS_EN 8191 -> 8189, measured on its SITL).
    "px4": ("LND_FLIGHT_T_HI", "LND_FLIGHT_T_LO", "COM_FLIGHT_UUID", "CAL_ACC*", "CAL_GYRO*", "EKF2_SENS_EN"),
}


def autopilot_updated(stack: str, name: str) -> bool:
    """Whether ``name`` is a parameter the ``stack`` autopilot writes itself (:data:`AUTOPILOT_UPDATED`; ``*``
    matches any suffix)."""
    return any(fnmatch.fnmatchcase(name, pat) for pat in AUTOPILOT_UPDATED.get(stack, ()))


@dataclass(frozen=True)
class Identity:
    """Who the vehicle is, from HEARTBEAT and AUTOPILOT_VERSION."""

    sysid: int
    compid: int
    autopilot: int
    vehicle_type: int
    vendor_id: int = 0
    product_id: int = 0
    flight_sw_version: int = 0
    capabilities: int = 0
    uid: int = 0

    @property
    def firmware(self) -> str:
        v = self.flight_sw_version
        kind = {0: "dev", 64: "alpha", 128: "beta", 192: "rc", 255: "official"}.get(v & 0xFF, str(v & 0xFF))
        return f"{v >> 24 & 0xFF}.{v >> 16 & 0xFF}.{v >> 8 & 0xFF}-{kind}"

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__} | {"firmware": self.firmware}


def detect_stack(ident: Identity) -> Stack:
    """Stack from the identity; :class:`VehicleError` for autopilots the tuner does not know."""
    if ident.autopilot == MAV_AUTOPILOT_ARDUPILOTMEGA:
        return ARDUPILOT
    if ident.autopilot == MAV_AUTOPILOT_PX4:
        return PX4
    if ident.autopilot == MAV_AUTOPILOT_GENERIC and ident.vendor_id == KSBO_VENDOR_ID:
        return KSBO_SIM
    raise VehicleError(f"unsupported autopilot (HEARTBEAT autopilot {ident.autopilot}, vendor "
                       f"0x{ident.vendor_id:04x}); supported: ArduPilot, PX4, the ksbo-mav simulator")


def default_profile(ident: Identity, stack: Stack) -> str:
    """Profile name for a vehicle when the user did not choose one."""
    if stack is KSBO_SIM:
        return "sim-planar" if ident.product_id in (0, KSBO_PRODUCT_PLANAR) else "ardupilot-copter"
    return "ardupilot-copter" if stack is ARDUPILOT else "px4-copter"


#: ArduPilot generation renames: new name -> (legacy name, scale) with ``new value = legacy value * scale``
#: (fact sheet 3.1; each checked against ArduPilot's AC_PosControl.cpp, docs/firmware.md). Names not listed are the
#: same in both generations (ATC_*, PSC_ANGLE_MAX, ...). PSC_JERK_NE/D are 4.7's names; master renamed them
#: PSC_NE_JERK/PSC_D_JERK later (July 2026): the tuner neither reads nor writes them.
ARDUPILOT_LEGACY = {
    "PSC_NE_POS_P": ("PSC_POSXY_P", 1.0),
    "PSC_NE_VEL_P": ("PSC_VELXY_P", 1.0),
    "PSC_NE_VEL_I": ("PSC_VELXY_I", 1.0),
    "PSC_NE_VEL_D": ("PSC_VELXY_D", 1.0),
    "PSC_NE_VEL_IMAX": ("PSC_VELXY_IMAX", 0.01),
    "PSC_NE_VEL_FF": ("PSC_VELXY_FF", 1.0),
    "PSC_NE_VEL_FLTE": ("PSC_VELXY_FLTE", 1.0),
    "PSC_NE_VEL_FLTD": ("PSC_VELXY_FLTD", 1.0),
    "PSC_D_POS_P": ("PSC_POSZ_P", 1.0),
    "PSC_D_VEL_P": ("PSC_VELZ_P", 1.0),
    "PSC_D_VEL_IMAX": ("PSC_VELZ_IMAX", 0.01),
    "PSC_D_ACC_P": ("PSC_ACCZ_P", 0.1),
    "PSC_D_ACC_I": ("PSC_ACCZ_I", 0.1),
    "PSC_D_ACC_D": ("PSC_ACCZ_D", 0.1),
    "PSC_D_ACC_IMAX": ("PSC_ACCZ_IMAX", 0.001),
    "PSC_D_ACC_FLTE": ("PSC_ACCZ_FLTE", 1.0),
    "PSC_D_ACC_FLTD": ("PSC_ACCZ_FLTD", 1.0),
    "PSC_JERK_NE": ("PSC_JERK_XY", 1.0),
    "PSC_JERK_D": ("PSC_JERK_Z", 1.0),
}
_LEGACY_TO_NEW = {old: (new, scale) for new, (old, scale) in ARDUPILOT_LEGACY.items()}


def ardupilot_generation(names: set[str] | Mapping[str, object]) -> str:
    """``"new"`` (PSC_NE_*), ``"legacy"`` (PSC_POSXY_*) from a downloaded parameter list."""
    has_new, has_old = "PSC_NE_POS_P" in names, "PSC_POSXY_P" in names
    if has_new and not has_old:
        return "new"
    if has_old and not has_new:
        return "legacy"
    raise VehicleError("cannot tell the ArduPilot parameter generation: the list has "
                       + ("both PSC_NE_POS_P and PSC_POSXY_P" if has_new else "neither PSC_NE_POS_P nor PSC_POSXY_P"))


def canonical_name(name: str) -> str:
    """Profile (newest-generation) name of a vehicle parameter name."""
    return _LEGACY_TO_NEW.get(name, (name, 1.0))[0]


@dataclass(frozen=True)
class GainMap:
    """Profile gains (canonical names, SI units; a gain vector) <-> the autopilot's parameters ({name: value}).

    Attributes:
        gain_names: profile gain names, in the profile's order.
        param_names: the matching autopilot parameter names.
        scale: ``gain value = parameter value * scale``.
        generation: "new", "legacy" (ArduPilot) or "" (other stacks).
    """

    gain_names: tuple[str, ...]
    param_names: tuple[str, ...]
    scale: tuple[float, ...]
    generation: str = ""

    @classmethod
    def build(cls, profile_names: list[str], stack: Stack, params: Mapping[str, object],
              profile: Profile | None = None) -> "GainMap":
        """Map a profile onto a downloaded parameter list; :class:`VehicleError` if a gain is missing.

        A profile gain may name its legacy parameter itself (``legacy_name``, ``legacy_scale``); otherwise the
        built-in :data:`ARDUPILOT_LEGACY` table applies.
        """
        generation = ardupilot_generation(params) if stack is ARDUPILOT else ""
        extras = {g.name: g.extra for g in profile.gains} if profile is not None else {}
        param_names, scale = [], []
        for name in profile_names:
            vname, s = name, 1.0
            if generation == "legacy":
                ex = extras.get(name, {})
                if "legacy_name" in ex:
                    vname, s = str(ex["legacy_name"]), float(ex.get("legacy_scale", 1.0))
                else:
                    vname, s = ARDUPILOT_LEGACY.get(name, (name, 1.0))
            if vname not in params:
                raise VehicleError(f"the vehicle has no parameter {vname} (profile gain {name}); "
                                   "wrong profile for this vehicle?")
            param_names.append(vname)
            scale.append(s)
        return cls(tuple(profile_names), tuple(param_names), tuple(scale), generation)

    def to_params(self, x: np.ndarray) -> dict[str, float]:
        """Gain vector (d,) -> {autopilot parameter name: parameter value}."""
        x = np.asarray(x, dtype=float)
        if x.shape != (len(self.gain_names),):
            raise InputError(f"expected {len(self.gain_names)} gains, got shape {x.shape}")
        return {v: float(xi) / s for v, xi, s in zip(self.param_names, x, self.scale)}

    def from_params(self, params: Mapping[str, float]) -> np.ndarray:
        """{autopilot parameter name: value} -> gain vector (d,)."""
        return np.array([float(params[p]) * s for p, s in zip(self.param_names, self.scale)])
