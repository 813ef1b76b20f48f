"""Autopilot parameter tables of the 3-D copter: names, defaults, ranges, types and the map onto internal gains.

Three name generations share one internal gain vector (:class:`PosGains` + :class:`AttitudeGains`):

* ``ardupilot``: ArduCopter 4.7, the names after PR #31513 (``PSC_NE_*``, ``PSC_D_*``; SI units), with the
  defaults and ranges of its AC_PosControl.cpp (docs/firmware.md says where they were read);
* ``ardupilot-legacy``: ArduCopter 4.5/4.6 and 4.7.0-dev of 2025 (``PSC_POSXY_*``, ``PSC_VELZ_*``,
  ``PSC_ACCZ_*``): IMAX in cm/s^2 (x 0.01), ACCZ P/I/D x 0.1 and ACCZ IMAX in d% (x 0.001) relative to the new
  names (fact sheet 3.1);
* ``px4``: ``MPC_*`` position loops (two-stage Z: the vehicle switches to the PX4 Z structure) and ``MC_*``
  attitude/rate loops with the rate law K (P e + I int e + D de/dt).

``internal = value * scale``. Defaults and ranges follow the fact sheet (sections 3.1, 3.2); where it gives no
range, the ArduPilot/PX4 parameter metadata range is used. INT32 parameters exist where the real stack has
integer parameters (ArduPilot ARMING_CHECK, ANGLE_MAX; PX4 MPC_POS_MODE, SYS_AUTOSTART, MC_AIRMODE) so the
endpoint's INT32 encoding (C-cast vs bytewise) is exercised; ANGLE_MAX is an INT16 on ArduPilot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ksbo_sim.copter3d.attitude import AttitudeGains
from ksbo_sim.copter3d.poscontrol import PosGains
from ksbo_sim.vehicle import ParamSpec


@dataclass(frozen=True)
class ParamMap:
    """One parameter and where it lands: ``target`` "pos" / "att" field (``index`` for per-axis lists)."""

    spec: ParamSpec
    target: str | None = None  # "pos", "att", or None (stored only)
    field: str = ""
    index: int | None = None
    scale: float = 1.0


def _p(name: str, default: float, lo: float, hi: float, target: str | None = None, fld: str = "",
       index: int | None = None, scale: float = 1.0, typ: str = "REAL32", desc: str = "") -> ParamMap:
    return ParamMap(ParamSpec(name, default, lo, hi, typ, desc), target, fld, index, scale)


def _ardupilot_psc(legacy: bool) -> list[ParamMap]:
    if legacy:
        return [
            _p("PSC_POSXY_P", 1.0, 0.5, 2.0, "pos", "ne_pos_p", desc="NE position P [(m/s)/m]"),
            _p("PSC_VELXY_P", 2.0, 0.1, 6.0, "pos", "ne_vel_p", desc="NE velocity P [(m/s^2)/(m/s)]"),
            _p("PSC_VELXY_I", 1.0, 0.02, 1.0, "pos", "ne_vel_i", desc="NE velocity I"),
            _p("PSC_VELXY_D", 0.25, 0.0, 1.0, "pos", "ne_vel_d", desc="NE velocity D"),
            _p("PSC_VELXY_IMAX", 1000.0, 0.0, 4500.0, "pos", "ne_vel_imax", scale=0.01, desc="[cm/s^2]"),
            _p("PSC_VELXY_FF", 0.0, 0.0, 6.0, "pos", "ne_vel_ff"),
            _p("PSC_VELXY_FLTE", 5.0, 0.0, 100.0, "pos", "ne_vel_flte", desc="[Hz]"),
            _p("PSC_VELXY_FLTD", 5.0, 0.0, 100.0, "pos", "ne_vel_fltd", desc="[Hz]"),
            _p("PSC_POSZ_P", 1.0, 1.0, 3.0, "pos", "d_pos_p", desc="D position P"),
            _p("PSC_VELZ_P", 5.0, 1.0, 8.0, "pos", "d_vel_p", desc="D velocity P"),
            _p("PSC_VELZ_IMAX", 1000.0, 1.0, 1000.0, desc="[cm/s^2] (stored)"),
            _p("PSC_ACCZ_P", 0.5, 0.2, 1.5, "pos", "d_acc_p", scale=0.1, desc="D accel P [thr per 10 m/s^2]"),
            _p("PSC_ACCZ_I", 1.0, 0.0, 3.0, "pos", "d_acc_i", scale=0.1),
            _p("PSC_ACCZ_D", 0.0, 0.0, 0.4, "pos", "d_acc_d", scale=0.1),
            _p("PSC_ACCZ_IMAX", 800.0, 0.0, 1000.0, "pos", "d_acc_imax", scale=0.001, desc="[d%]"),
            _p("PSC_ACCZ_FLTE", 20.0, 1.0, 100.0, "pos", "d_acc_flte", desc="[Hz]"),
            _p("PSC_ACCZ_FLTD", 0.0, 0.0, 100.0, desc="[Hz] (stored; the accel D gain is 0)"),
            _p("PSC_JERK_XY", 5.0, 1.0, 20.0, desc="[m/s^3] (stored; targets are not re-shaped)"),
            _p("PSC_JERK_Z", 5.0, 5.0, 50.0, desc="[m/s^3] (stored)"),
        ]
    # ArduCopter 4.7 (the AC_PosControl.cpp parameter table after PR #31513; docs/firmware.md): ranges as its @Range
    # lines, defaults as its Copter defaults. Where a documented range excludes the default (FF 0.1-10 and FLTD
    # 1-100 with defaults 0), the range starts at the default so the default itself is settable here.
    return [
        _p("PSC_NE_POS_P", 1.0, 0.5, 4.0, "pos", "ne_pos_p", desc="NE position P [(m/s)/m]"),
        _p("PSC_NE_VEL_P", 2.0, 0.1, 10.0, "pos", "ne_vel_p", desc="NE velocity P [(m/s^2)/(m/s)]"),
        _p("PSC_NE_VEL_I", 1.0, 0.1, 10.0, "pos", "ne_vel_i", desc="NE velocity I"),
        _p("PSC_NE_VEL_D", 0.25, 0.0, 1.0, "pos", "ne_vel_d", desc="NE velocity D"),
        _p("PSC_NE_VEL_IMAX", 10.0, 0.0, 10.0, "pos", "ne_vel_imax", desc="[m/s^2] (4.6: PSC_VELXY_IMAX x 0.01)"),
        _p("PSC_NE_VEL_FF", 0.0, 0.0, 10.0, "pos", "ne_vel_ff"),
        _p("PSC_NE_VEL_FLTE", 5.0, 0.0, 100.0, "pos", "ne_vel_flte", desc="[Hz]"),
        _p("PSC_NE_VEL_FLTD", 5.0, 0.0, 100.0, "pos", "ne_vel_fltd", desc="[Hz]"),
        _p("PSC_D_POS_P", 1.0, 0.5, 4.0, "pos", "d_pos_p", desc="D position P"),
        _p("PSC_D_VEL_P", 5.0, 1.0, 10.0, "pos", "d_vel_p", desc="D velocity P"),
        _p("PSC_D_VEL_IMAX", 10.0, 1.0, 10.0, desc="[m/s^2] (stored; 4.6: PSC_VELZ_IMAX x 0.01)"),
        _p("PSC_D_ACC_P", 0.05, 0.01, 0.25, "pos", "d_acc_p", desc="D accel P (4.6: PSC_ACCZ_P x 0.1)"),
        _p("PSC_D_ACC_I", 0.1, 0.0, 0.5, "pos", "d_acc_i", desc="(4.6: PSC_ACCZ_I x 0.1)"),
        _p("PSC_D_ACC_D", 0.0, 0.0, 0.1, "pos", "d_acc_d", desc="(4.6: PSC_ACCZ_D x 0.1)"),
        _p("PSC_D_ACC_IMAX", 0.8, 0.0, 1.0, "pos", "d_acc_imax", desc="(4.6: PSC_ACCZ_IMAX x 0.001)"),
        _p("PSC_D_ACC_FLTE", 20.0, 1.0, 100.0, "pos", "d_acc_flte", desc="[Hz]"),
        _p("PSC_D_ACC_FLTD", 0.0, 0.0, 100.0, desc="[Hz] (stored; the accel D gain is 0)"),
        _p("PSC_JERK_NE", 5.0, 1.0, 50.0, desc="[m/s^3] (stored; targets are not re-shaped)"),
        _p("PSC_JERK_D", 5.0, 1.0, 50.0, desc="[m/s^3] (stored)"),
    ]


def _ardupilot_common() -> list[ParamMap]:
    rows = [_p("PSC_ANGLE_MAX", 0.0, 0.0, 45.0, desc="lean limit [deg], 0 = ANGLE_MAX"),
            _p("ANGLE_MAX", 3000, 1000, 8000, typ="INT32", desc="lean limit [cdeg]"),
            _p("ARMING_CHECK", 1, 0, 2**31 - 1, typ="INT32", desc="arming check bitmask (stored)")]
    for i, ax in enumerate(("RLL", "PIT")):
        rows += [_p(f"ATC_ANG_{ax}_P", 4.5, 3.0, 12.0, "att", "ang_p", i),
                 _p(f"ATC_RAT_{ax}_P", 0.135, 0.01, 0.5, "att", "rat_p", i),
                 _p(f"ATC_RAT_{ax}_I", 0.135, 0.01, 2.0, "att", "rat_i", i),
                 _p(f"ATC_RAT_{ax}_D", 0.0036, 0.0, 0.05, "att", "rat_d", i),
                 _p(f"ATC_RAT_{ax}_IMAX", 0.5, 0.0, 1.0, "att", "rat_imax", i)]
    rows += [_p("ATC_ANG_YAW_P", 4.5, 3.0, 12.0, "att", "ang_p", 2),
             _p("ATC_RAT_YAW_P", 0.18, 0.1, 2.5, "att", "rat_p", 2),
             _p("ATC_RAT_YAW_I", 0.018, 0.01, 1.0, "att", "rat_i", 2),
             _p("ATC_INPUT_TC", 0.15, 0.0, 1.0, "att", "input_tc", desc="attitude input time constant [s]")]
    return rows


def _px4() -> list[ParamMap]:
    rows = [
        _p("MPC_XY_P", 0.95, 0.0, 2.0, "pos", "ne_pos_p", desc="NE position P [1/s]"),
        _p("MPC_XY_VEL_P_ACC", 1.8, 1.2, 5.0, "pos", "ne_vel_p", desc="NE velocity P [1/s]"),
        _p("MPC_XY_VEL_I_ACC", 0.4, 0.0, 60.0, "pos", "ne_vel_i", desc="NE velocity I [1/s^2]"),
        _p("MPC_XY_VEL_D_ACC", 0.2, 0.1, 2.0, "pos", "ne_vel_d", desc="NE velocity D [-]"),
        _p("MPC_Z_P", 1.0, 0.1, 1.5, "pos", "d_pos_p", desc="D position P [1/s]"),
        _p("MPC_Z_VEL_P_ACC", 4.0, 2.0, 15.0, "pos", "d_vel_p", desc="D velocity P [1/s]"),
        _p("MPC_Z_VEL_I_ACC", 2.0, 0.2, 3.0, "pos", "d_vel_i", desc="D velocity I [1/s^2]"),
        _p("MPC_Z_VEL_D_ACC", 0.0, 0.0, 2.0, "pos", "d_vel_d", desc="D velocity D [-]"),
        _p("MPC_XY_VEL_MAX", 12.0, 0.0, 20.0, "pos", "vel_max_ne", desc="[m/s]"),
        _p("MPC_TILTMAX_AIR", 45.0, 20.0, 89.0, "pos", "angle_max_deg", desc="[deg]"),
        _p("MPC_POS_MODE", 4, 0, 4, typ="INT32", desc="stick input mode (stored)"),
        _p("SYS_AUTOSTART", 4001, 0, 9999999, typ="INT32", desc="airframe id (stored)"),
        _p("MC_AIRMODE", 0, 0, 2, typ="INT32", desc="(stored)"),
    ]
    for i, ax in enumerate(("ROLL", "PITCH")):
        rows += [_p(f"MC_{ax}_P", 6.5, 0.0, 12.0, "att", "ang_p", i),
                 _p(f"MC_{ax}RATE_P", 0.15, 0.01, 0.5 if i == 0 else 0.6, "att", "rat_p", i),
                 _p(f"MC_{ax}RATE_I", 0.2, 0.0, 1.0, "att", "rat_i", i),
                 _p(f"MC_{ax}RATE_D", 0.003, 0.0, 0.01, "att", "rat_d", i),
                 _p(f"MC_{ax}RATE_K", 1.0, 0.01, 5.0, desc="rate law gain K")]
    rows += [_p("MC_YAW_P", 2.8, 0.0, 5.0, "att", "ang_p", 2),
             _p("MC_YAWRATE_P", 0.2, 0.0, 0.6, "att", "rat_p", 2),
             _p("MC_YAWRATE_I", 0.1, 0.0, 1.0, "att", "rat_i", 2),
             _p("MC_YAWRATE_D", 0.0, 0.0, 0.01, "att", "rat_d", 2),
             _p("MC_YAWRATE_K", 1.0, 0.0, 5.0, desc="rate law gain K")]
    return rows


#: Geofence parameter names per stack: (horizontal radius from home [m], max altitude above home [m]).
FENCE_NAMES = {"ardupilot": ("FENCE_RADIUS", "FENCE_ALT_MAX"), "px4": ("GF_MAX_HOR_DIST", "GF_MAX_VER_DIST")}
#: Tilt beyond which the simulator declares a crash (a simulator setting, like ArduPilot SITL's SIM_*).
TILT_CRASH = "SIM_TILT_CRASH"
#: The hover thrust fraction each stack reports (ArduPilot learns MOT_THST_HOVER, PX4 MPC_THR_HOVER). On this
#: simulator it is the airframe's: the vehicle reports what the F450 hovers at, and a value written makes the
#: airframe hover there (each motor gives as-built hover / value of the thrust commanded), with the position
#: loop's hover feed-forward set to it, as after an autopilot's hover learning.
HOVER_NAMES = {"ardupilot": "MOT_THST_HOVER", "px4": "MPC_THR_HOVER"}


def _settings(stack: str) -> list[ParamMap]:
    hor, ver = FENCE_NAMES[stack]
    return [_p(hor, 100.0, 10.0, 10000.0, desc="geofence: horizontal distance from home [m] (crash)"),
            _p(ver, 50.0, 5.0, 1000.0, desc="geofence: altitude above home [m] (crash)"),
            _p(TILT_CRASH, 85.0, 10.0, 180.0, desc="roll or pitch beyond this is a crash [deg]"),
            _p(HOVER_NAMES[stack], 0.22, 0.1, 0.8, desc="hover thrust fraction (the airframe's; set: a lighter or "
               "heavier airframe)")]


#: Personality name -> parameter table (tunable position gains first).
TABLES: dict[str, list[ParamMap]] = {
    "ardupilot": _ardupilot_psc(legacy=False) + _ardupilot_common() + _settings("ardupilot"),
    "ardupilot-legacy": _ardupilot_psc(legacy=True) + _ardupilot_common() + _settings("ardupilot"),
    "px4": _px4() + _settings("px4"),
}

#: Equivalent names across generations (canonical internal field -> name per personality), for the profiles.
EQUIVALENT: dict[str, dict[str, str]] = {}
for _pers, _rows in TABLES.items():
    for _r in _rows:
        if _r.target == "pos":
            EQUIVALENT.setdefault(_r.field, {})[_pers] = _r.spec.name


def build_gains(personality: str, values: dict[str, float]) -> tuple[PosGains, AttitudeGains]:
    """Internal gains from the parameter values of ``personality`` (missing names take their defaults)."""
    table = TABLES[personality]
    vals = {r.spec.name: float(values.get(r.spec.name, r.spec.default)) for r in table}
    pos, att = PosGains(), AttitudeGains()
    for r in table:
        if r.target is None:
            continue
        obj = pos if r.target == "pos" else att
        v = vals[r.spec.name] * r.scale
        if r.index is None:
            setattr(obj, r.field, v)
        else:
            getattr(obj, r.field)[r.index] = v
    if personality == "px4":
        # Rate law K (P e + I int e + D de/dt); PX4 has no attitude input shaping, so only a short tc.
        for i, ax in enumerate(("ROLL", "PITCH", "YAW")):
            k = vals[f"MC_{ax}RATE_K"]
            att.rat_p[i] *= k
            att.rat_i[i] *= k
            att.rat_d[i] *= k
        att.input_tc = 0.05
        pos.vel_max_d = 3.0  # MPC_Z_VEL_MAX_UP default
    else:
        pam = vals["PSC_ANGLE_MAX"]
        pos.angle_max_deg = pam if pam > 0 else vals["ANGLE_MAX"] / 100.0
        pos.angle_max_deg = min(pos.angle_max_deg, 80.0)
    if not math.isfinite(pos.angle_max_deg) or pos.angle_max_deg <= 0:
        pos.angle_max_deg = 30.0
    return pos, att


def param_specs(personality: str) -> list[ParamSpec]:
    """The ParamSpec list of a personality, tunable gains first (the order of ``TABLES``)."""
    return [r.spec for r in TABLES[personality]]
