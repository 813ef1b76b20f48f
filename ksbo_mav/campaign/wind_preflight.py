"""The day's wind, known before takeoff (``tune --wind M/S``): will the baseline's figure-8 lean past the tilt
limit in it, and if so the way forward, decided on the ground and said in the plan.

The lean a figure-8 needs: the thrust's horizontal part must give the pattern's acceleration and cancel the drag of
the air moving past, ``a_thrust = a_ref + (c_lin + c_quad |v_ref - w|)(v_ref - w)`` (the drag model of
:mod:`ksbo_mav.flightlog.wind_fit`, ``w`` where the wind blows to), so the lean is ``atan(|a_thrust| / g)``. The
wind's direction is not asked: the peak is taken over every direction. The drag coefficients, in this order: the
simulator's own (PX4 SIH: ``SIH_KDV / SIH_MASS``, linear), the vehicle's drag-fusion setting where it is on (PX4
``EKF2_DRAG_CTRL`` with ``EKF2_MCOEF``/``EKF2_BCOEF_X``; ArduPilot ``EK3_DRAG_MCOEF``/``EK3_DRAG_BCOEF_X``), else
PX4's default drag-fusion coefficients as a typical quad's (a guess, and said so).

The way forward, first that fits (``HEADROOM_DEG`` between the predicted peak and the limit):

1. the predicted peak fits the profile's tilt limit: nothing changes;
2. the vehicle's own lean limit (``MPC_TILTMAX_AIR``; ``PSC_ANGLE_MAX``, else ``ANGLE_MAX``) less ``MARGIN_DEG`` is
   above the profile's and leaves room: the monitor's (and the onboard guard's) tilt limit becomes that;
3. the figure-8 scaled down (north and east amplitudes, same period) until its peak fits the larger of the two
   limits: the baseline, every trial and the score fly that smaller pattern;
4. nothing fits: refused in one line (wait for less wind).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_task.figure8_ne import Figure8H

G = 9.80665
RHO = 1.225  # kg/m^3, sea level: ballistic coefficient -> quadratic drag
#: Below the vehicle's own lean limit: its controller saturates there, and a monitor at the limit trips on noise.
MARGIN_DEG = 3.0
#: Between the predicted peak lean and the limit it must fit: the prediction ignores the gains' tracking error.
HEADROOM_DEG = 2.0
#: Figure-8 scales tried, largest first.
SCALES = (0.9, 0.8, 0.7, 0.6, 0.5, 0.4)


@dataclass(frozen=True)
class Drag:
    c_lin: float  # 1/s
    c_quad: float  # 1/m
    source: str


def vehicle_drag(params: Mapping[str, float]) -> Drag:
    """The drag coefficients to predict with ({name: value} of the vehicle's parameters), with where they came
    from."""
    p = params
    if p.get("SIH_KDV") is not None and p.get("SIH_MASS"):
        c = p["SIH_KDV"] / p["SIH_MASS"]
        return Drag(c, 0.0, f"the simulator's SIH_KDV / SIH_MASS = {c:.3g} 1/s")
    if p.get("EKF2_DRAG_CTRL") and p.get("EKF2_MCOEF") is not None:
        b = p.get("EKF2_BCOEF_X") or 0.0
        return Drag(p["EKF2_MCOEF"], 0.5 * RHO / b if b > 0 else 0.0,
                    "the vehicle's drag fusion (EKF2_MCOEF, EKF2_BCOEF_X)")
    if p.get("EK3_DRAG_MCOEF") or p.get("EK3_DRAG_BCOEF_X"):
        b = p.get("EK3_DRAG_BCOEF_X") or 0.0
        return Drag(p.get("EK3_DRAG_MCOEF") or 0.0, 0.5 * RHO / b if b > 0 else 0.0,
                    "the vehicle's drag fusion (EK3_DRAG_MCOEF, EK3_DRAG_BCOEF_X)")
    return Drag(0.15, 0.5 * RHO / 100.0, "a typical quad's (PX4's default EKF2_MCOEF 0.15 1/s, EKF2_BCOEF_X 100 "
                                         "kg/m^2): a guess, not this vehicle's")


def own_tilt_limit(stack: str, params: Mapping[str, float]) -> tuple[float, str] | None:
    """The vehicle's own lean limit (deg) and the parameter it comes from, where the stack has one."""
    if stack == "px4" and params.get("MPC_TILTMAX_AIR"):
        return float(params["MPC_TILTMAX_AIR"]), "MPC_TILTMAX_AIR"
    if params.get("PSC_ANGLE_MAX"):
        return float(params["PSC_ANGLE_MAX"]), "PSC_ANGLE_MAX"
    if params.get("ANGLE_MAX"):
        return float(params["ANGLE_MAX"]) / 100.0, "ANGLE_MAX"
    return None


def peak_lean_deg(f8: Figure8H, wind_mps: float, drag: Drag, directions: int = 24) -> float:
    """The largest lean (deg) the figure-8 ``f8`` needs in a wind of ``wind_mps`` from the worst direction."""
    t = np.arange(0.0, f8.laps * f8.period, 0.05)
    _, vel, acc = f8.state(t)
    v, a = vel[:, :2], acc[:, :2]
    peak = 0.0
    for k in range(directions):
        ang = 2.0 * math.pi * k / directions
        air = v - wind_mps * np.array([math.cos(ang), math.sin(ang)])
        speed = np.linalg.norm(air, axis=1, keepdims=True)
        thrust = a + (drag.c_lin + drag.c_quad * speed) * air
        peak = max(peak, float(np.max(np.linalg.norm(thrust, axis=1))))
    return math.degrees(math.atan(peak / G))


@dataclass(frozen=True)
class WindPlan:
    """What was decided: ``tilt_max_deg`` the monitor's limit, ``scale`` of the figure-8 (1: as the profile), and
    the plan's words."""

    wind_mps: float
    predicted_deg: float  # at the profile's figure-8
    tilt_max_deg: float
    scale: float
    text: str


def plan_for_wind(wind_mps: float, f8: Figure8H, tilt_max_deg: float, stack: str,
                  params: Mapping[str, float]) -> WindPlan:
    """The way forward for ``wind_mps`` (see the module's docstring); :class:`InputError` when none fits."""
    drag = vehicle_drag(params)
    peak = peak_lean_deg(f8, wind_mps, drag)
    said = (f"wind {wind_mps:g} m/s (declared): the figure-8 needs up to {peak:.1f} deg of lean from the worst "
            f"direction (drag: {drag.source})")
    if peak + HEADROOM_DEG <= tilt_max_deg:
        return WindPlan(wind_mps, peak, tilt_max_deg, 1.0, f"{said}; it fits the tilt limit {tilt_max_deg:g} deg")
    own = own_tilt_limit(stack, params)
    raised = own[0] - MARGIN_DEG if own and own[0] - MARGIN_DEG > tilt_max_deg else None
    if raised is not None and peak + HEADROOM_DEG <= raised:
        return WindPlan(wind_mps, peak, raised, 1.0,
                        f"{said}, past the profile's tilt limit {tilt_max_deg:g} deg: the limit is raised to "
                        f"{raised:g} deg ({own[1]} {own[0]:g} deg less {MARGIN_DEG:g})")
    limit = max(tilt_max_deg, raised or tilt_max_deg)
    for s in SCALES:
        scaled = replace(f8, amp_north=f8.amp_north * s, amp_east=f8.amp_east * s)
        p = peak_lean_deg(scaled, wind_mps, drag)
        if p + HEADROOM_DEG <= limit:
            why = (f"the limit raised to {limit:g} deg ({own[1]} {own[0]:g} deg less {MARGIN_DEG:g}) and "
                   if raised else "")
            return WindPlan(wind_mps, peak, limit, s,
                            f"{said}, past the tilt limit {tilt_max_deg:g} deg: {why}the figure-8 scaled to "
                            f"{s:.0%} ({2 * scaled.amp_north:g} m x {2 * scaled.amp_east:g} m, {p:.1f} deg)")
    raise InputError(f"{said}: more than the tilt limit ({limit:g} deg) allows even with the figure-8 at "
                     f"{SCALES[-1]:.0%}; fly in less wind")


def apply_wind_plan(cfg: Any, v: Any, log: Any) -> Any:
    """The hook before takeoff (and in ``--dry-run``): with ``cfg.wind_mps`` set, decide, log the plan's line, set
    the monitor's tilt limit in the settings and the figure-8's scale on the vehicle's mission; returns the
    settings."""
    if cfg.wind_mps is None or v.mission.kind != "figure8-ne":
        return cfg
    m = v.mission
    f8 = Figure8H(amp_north=m.scale, amp_east=m.scale2, period=m.period, altitude=m.center_up, lead_in=m.lead_in)
    tilt = float(cfg.safety.get("tilt_max_deg", v.profile.safety.tilt_max_deg))
    params = {n: float(p.value) for n, p in v.params.table.items()}
    wp = plan_for_wind(float(cfg.wind_mps), f8, tilt, v.stack.name, params)
    log(wp.text)
    v.wind_plan = wp.text
    if wp.scale != 1.0:
        v.mission = replace(m, scale=m.scale * wp.scale, scale2=m.scale2 * wp.scale)
    if wp.tilt_max_deg != tilt:
        cfg = replace(cfg, safety={**cfg.safety, "tilt_max_deg": wp.tilt_max_deg})
    return cfg
