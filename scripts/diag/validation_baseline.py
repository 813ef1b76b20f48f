"""Diagnostic: the validation manoeuvres flown with a SITL's own (baseline) gains, repeated, and their figures.

Starts an ArduCopter or PX4 SITL (a fresh one, on an instance number no other process holds:
``ksbo_sim.sitl_instances``, the registry the tests use), takes off, flies the position steps, the autopilot's
hold and the AUTO / Mission box (``ksbo_mav.mav.validation``) ``--repeats`` times in turn, lands, and prints each
flight's headline figures and their mean and spread as a Markdown table (``--json`` for every figure). The bench
settings it needs are the ones docs/sitl.md gives: PX4 ``COM_RCL_EXCEPT 4``; ArduCopter's sticks centred on its
RC input port once airborne (LOITER flies them). ``--wind`` sets ArduCopter's ``SIM_WIND_SPD`` (from the north,
turbulence 1).

    python scripts/diag/validation_baseline.py ardupilot --speed 10 [--wind 5] [--sizes quick]
    python scripts/diag/validation_baseline.py px4 --speed 1 --steps-m 3
"""

from __future__ import annotations

import argparse
import json
import math
import socket
import struct
import tempfile
from pathlib import Path

import numpy as np

FIGURES = {"steps": ("rise_s_mean", "overshoot_pct_mean", "settle_s_mean"),
           "hold": ("hold_rms_m", "hold_max_m", "hold_lean_deg"),
           "auto_mission": ("xtrack_rms_m", "xtrack_max_m", "corner_overshoot_m_mean", "time_s")}


def fly(kind: str, speed: float, wind: float, sizes: str, repeats: int, steps_m: float,
        out_dir: Path) -> dict[str, list[dict[str, float]]]:
    from ksbo_mav.mav.link import Endpoint
    from ksbo_mav.mav.monitor import Monitor, limits_from_profile
    from ksbo_mav.mav.validation import ManoeuvreSpec, fly_manoeuvre
    from ksbo_mav.mav.vehicle import Vehicle
    from ksbo_sim.sitl_instances import start_claimed

    sitl = start_claimed(kind, speed)  # an instance number no other process holds
    got: dict[str, list[dict[str, float]]] = {}
    try:
        if kind == "px4":
            sitl.set_param("COM_RCL_EXCEPT", 4, int32=True)
            ep = Endpoint("udp", "127.0.0.1", sitl.udp_port)
        else:
            for name, value in (("SIM_WIND_SPD", wind), ("SIM_WIND_DIR", 0.0), ("SIM_WIND_TURB", 1.0 if wind else 0)):
                sitl.set_param(name, value)
            ep = Endpoint("tcp", "127.0.0.1", sitl.tcp_ports[1])
        v = Vehicle.connect(ep, "ardupilot-copter" if kind == "ardupilot" else "px4-copter", timeout=30)
        try:
            v.setup_streams()
            mon = Monitor(limits_from_profile(v.profile), v.stack.modes["guided"], v.stack.mode_name)
            v.ensure_airborne()
            if kind == "ardupilot":  # LOITER flies the sticks: centre them (after arming: a centred throttle blocks it)
                with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
                    s.sendto(struct.pack("<16H", *([1500] * 4 + [0] * 12)), ("127.0.0.1", 5501 + 10 * sitl.instance))
            offsets = [[steps_m, 0, 0], [0, steps_m, 0], [0, 0, -2]]
            for r in range(repeats):
                for m in FIGURES:
                    spec = ManoeuvreSpec.from_dict(m, {"offsets_m": offsets} if m == "steps" else {})
                    spec = spec.quick() if sizes == "quick" else spec
                    f = fly_manoeuvre(v, spec, mon, gains_label="baseline", tlog_path=out_dir / f"{m}_{r}.tlog")
                    print(f"{m} {r + 1}: {f.outcome} {f.message}", flush=True)
                    got.setdefault(m, []).append(f.metrics if str(f.outcome) == "ok" else {})
            v.land()
        finally:
            v.close()
    finally:
        sitl.stop()
    return got


def table(got: dict[str, list[dict[str, float]]]) -> list[str]:
    lines = ["| manoeuvre | figure | flights | mean | min .. max |", "|---|---|---|---|---|"]
    for m, names in FIGURES.items():
        for name in names:
            vals = [f[name] for f in got.get(m, []) if name in f and math.isfinite(f[name])]
            if vals:
                lines.append(f"| {m} | {name} | {len(vals)} of {len(got[m])} | {np.mean(vals):.3f} | "
                             f"{min(vals):.3f} .. {max(vals):.3f} |")
            else:
                lines.append(f"| {m} | {name} | 0 of {len(got.get(m, []))} | n/a | |")
    return lines


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("kind", choices=("ardupilot", "px4"))
    p.add_argument("--speed", type=float, default=1.0, help="SITL speed-up (PX4 above 2 drops OFFBOARD on a busy "
                                                            "machine)")
    p.add_argument("--wind", type=float, default=0.0, help="ArduCopter SIM_WIND_SPD (m/s, from the north)")
    p.add_argument("--sizes", choices=("quick", "full"), default="full")
    p.add_argument("--repeats", type=int, default=2)
    p.add_argument("--steps-m", type=float, default=5.0, help="the horizontal step size (PX4: 3)")
    p.add_argument("--out", default=None, help="folder for the tlogs (default: a temporary one)")
    p.add_argument("--json", action="store_true")
    a = p.parse_args()
    out = Path(a.out or tempfile.mkdtemp(prefix="validation-baseline-"))
    out.mkdir(parents=True, exist_ok=True)
    got = fly(a.kind, a.speed, a.wind, a.sizes, a.repeats, a.steps_m, out)
    print(json.dumps(got, indent=1) if a.json else "\n".join(table(got)))
    print(f"tlogs: {out}")


if __name__ == "__main__":
    main()
