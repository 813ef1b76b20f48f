"""A cell's vehicle and condition in words, for the tables of the campaign and flights sweeps' pages."""

from __future__ import annotations

import statistics
from typing import Any

VEHICLE = {"ardupilot": "ArduCopter SITL", "px4": "PX4 SITL", "copter3d": "JSBSim copter", "planar": "planar"}


def vehicle(key: dict[str, Any]) -> str:
    return VEHICLE.get(key.get("vehicle", ""), key.get("vehicle", "?"))


def _sim_args(args: list[str]) -> list[str]:
    out, a = [], list(map(str, args))
    if "--drag" in a:
        scale, _, rise = a[a.index("--drag") + 1].partition(",")
        out.append(f"drag +{rise}/min of flight" if rise else f"drag ×{float(scale):g}")
    if "--noise" in a:
        out.append(f"sensor noise {a[a.index('--noise') + 1]}")
    return out


def condition(key: dict[str, Any]) -> str:
    """"calm", "wind 5 m/s (turbulence 1)", "wind 0 → 6 m/s at trial 15", "drag ×1.5", "link: down=4000,…"."""
    out = []
    sp = key.get("sitl_params") or {}
    if sp.get("SIM_WIND_SPD"):
        turb = sp.get("SIM_WIND_TURB")
        out.append(f"wind {sp['SIM_WIND_SPD']:g} m/s" + (f" (turbulence {turb:g})" if turb else ""))
    if sp.get("SIM_GYR1_RND") or sp.get("SIM_ACC1_RND"):  # ArduPilot SITL's sensor noise
        gps = f", GPS at {sp['SIM_GPS1_HZ']:g} Hz" if sp.get("SIM_GPS1_HZ") else ""
        out.append(f"sensor noise (gyros {sp.get('SIM_GYR1_RND', 0):g} deg/s, accelerometers "
                   f"{sp.get('SIM_ACC1_RND', 0):g} m/s²{gps})")
    if key.get("change_params", {}).get("SIM_WIND_SPD"):
        out.append(f"wind 0 → {key['change_params']['SIM_WIND_SPD']:g} m/s at trial {key['change_at']}")
    out += _sim_args(key.get("sim_args", []))
    if key.get("link"):
        out.append("through a radio-like link")
    return ", ".join(out) or "calm"


def mean(xs: list[float | None] | None) -> float | None:
    v = [x for x in xs or [] if x is not None]
    return statistics.mean(v) if v else None


def fmt(x: float | None, spec: str = ".3f") -> str:
    return "–" if x is None else format(x, spec)


def spread(xs: list[float | None] | None, spec: str = ".4g") -> str:
    """"mean (min–max)" of the values that are there."""
    v = [x for x in xs or [] if x is not None]
    if not v:
        return "–"
    return f"{format(statistics.mean(v), spec)} ({format(min(v), spec)}–{format(max(v), spec)})" if len(v) > 1 \
        else format(v[0], spec)


def machine_line(recs: list[dict[str, Any]]) -> str:
    """The newest record's machine and date."""
    newest = max(recs, key=lambda r: r.get("run", {}).get("started") or "")
    run = newest.get("run", {})
    return f"{run.get('machine')}, {(run.get('started') or 'undated')[:16].replace('T', ' ')} UTC"
