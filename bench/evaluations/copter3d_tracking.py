"""Evaluation ``copter3d-tracking``: our JSBSim copter's lap-2 tracking against its gains, in process, in the
layout of the SITL fact sheet's gain table (ArduCopter SITL 4.7.0-dev values beside): the default gains and one
gain changed at a time, on the horizontal figure-8 (``variant = "xy"``, the mission) or its x-z variant (``xz``,
the second term on down, where the Z gains matter); and (``variant = "stock"``) the stock F450 files without the
rotor-drag term, which track ten times better than SITL (hence the calibrated drag). ``personality``: the gain
names (default ardupilot-legacy, the fact sheet's)."""

from __future__ import annotations

from typing import Any

from ksbo_bench.cell_errors import SweepError

#: (parameter, value, SITL lap-2 RMS on the affected axis from the fact sheet, axis) for the x-z variant.
SITL_XZ = [
    (None, None, "x 0.20-0.23, z 0.040", None),
    ("PSC_POSXY_P", 0.5, "x 0.353", 0),
    ("PSC_POSXY_P", 2.0, "x 0.105", 0),
    ("PSC_VELXY_P", 4.0, "x 0.156", 0),
    ("PSC_VELXY_P", 1.0, "x 0.231 (noise)", 0),
    ("PSC_POSZ_P", 0.5, "z 0.063", 2),
    ("PSC_POSZ_P", 2.0, "z 0.021", 2),
    ("PSC_VELZ_P", 2.0, "z 0.097", 2),
    ("PSC_ACCZ_P", 0.2, "z 0.043", 2),
]
VARIANTS = {"xy": 1, "xz": 2, "stock": 1}


def check(key: dict[str, Any]) -> None:
    if key.get("variant", "xy") not in VARIANTS:
        raise SweepError(f"copter3d-tracking: variant must be one of {', '.join(VARIANTS)}")


def run(key: dict[str, Any]) -> dict[str, Any]:
    from ksbo_sim.copter3d import Copter3D, fly
    from ksbo_task.figure8_ne import Figure8H

    variant, pers = key.get("variant", "xy"), key.get("personality", "ardupilot-legacy")
    fig = Figure8H(second_axis=VARIANTS[variant])
    if variant == "stock":
        f = fly(Copter3D(pers, rotor_drag=0.0), fig)
        return {"rows": [{"gains": "defaults, no rotor drag", "rms_lap2": f.rms_lap2, "sitl": "0.234 (drag on)"}]}
    v = Copter3D(pers)
    cases = SITL_XZ if variant == "xz" else [c for c in SITL_XZ if c[3] in (None, 0)]
    rows = []
    for name, value, sitl, _ in cases:
        default = v.get_param(name) if name else None
        if name:
            v.set_param(name, value)
        f = fly(v, fig)
        if name:
            v.set_param(name, default)
        x, y, z = f.rms_lap2_axes
        rows.append({"gains": "defaults" if name is None else f"`{name}` {default:g} -> {value:g}",
                     "rms_lap2": f.rms_lap2, "axes": [x, y, z], "rms_all": f.rms_all, "max_error": f.max_error,
                     "max_tilt_deg": f.max_tilt_deg, "sitl": sitl if variant == "xz" else ""})
    return {"rows": rows}


TITLES = {"xy": "x-y figure-8 (the mission: north 10 sin wt, east 2.5 sin 2wt, 10 m up)",
          "xz": "x-z variant (second term on down), as in the fact sheet's gain table",
          "stock": "stock F450 files without the rotor-drag term (SITL at default gains beside)"}


def report(recs: list[dict[str, Any]]) -> str:
    out = []
    for r in recs:
        variant = r["key"].get("variant", "xy")
        out += [f"**{TITLES[variant]}**", ""]
        if variant == "stock":
            out += ["| gains | lap-2 RMS (m) | SITL lap 2 (m) |", "|---|---|---|",
                    *(f"| {x['gains']} | {x['rms_lap2']:.3f} | {x['sitl']} |" for x in r["result"]["rows"]), ""]
            continue
        out += ["| gains | lap-2 RMS (m) | lap-2 x / y / z (m) | RMS all (m) | max error (m) | max tilt (deg) | "
                "SITL lap 2 (fact sheet) |", "|---|---|---|---|---|---|---|"]
        out += [f"| {x['gains']} | {x['rms_lap2']:.3f} | {' / '.join(f'{a:.3f}' for a in x['axes'])} | "
                f"{x['rms_all']:.2f} | {x['max_error']:.2f} | {x['max_tilt_deg']:.1f} | {x['sitl']} |"
                for x in r["result"]["rows"]]
        out.append("")
    return "\n".join(out).strip()
