"""Fly the validation's AUTO mission once on a fresh PX4 SITL and print what the vehicle said while it did:
STATUSTEXT, the EVENT messages (id 410, which pymavlink's dialect here does not decode; their text looked up in the
build's own etc/extras/all_events.json.xz), MISSION_CURRENT (seq, total, mission_state) and mode changes, with the
vehicle's boot time. How the reason PX4 main left its mission at once was found (docs/firmware.md).

    python scripts/diag/px4_mission_events.py [--build main] [--speedup 5]
"""

from __future__ import annotations

import argparse
import json
import lzma
import os
import struct
import tempfile
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")

from ksbo_mav.mav.monitor import Monitor, limits_from_profile  # noqa: E402
from ksbo_mav.mav.link import Endpoint  # noqa: E402
from ksbo_mav.mav.validation import ManoeuvreSpec, fly_manoeuvre  # noqa: E402
from ksbo_mav.mav.vehicle import Vehicle  # noqa: E402
from ksbo_sim.sitl import find_run_script  # noqa: E402
from ksbo_sim.sitl_instances import release_stopped, start_claimed  # noqa: E402


def events_table(build: str | None) -> dict[int, str]:
    """{24-bit event id: message} of the PX4 build's all_events.json.xz (component 1, the autopilot)."""
    path = Path(find_run_script("px4", build)).parent / "etc" / "extras" / "all_events.json.xz"
    if not path.exists():
        return {}
    d = json.loads(lzma.decompress(path.read_bytes()))
    return {int(eid): e["message"] for grp in d["components"].get("1", {}).get("event_groups", {}).values()
            for eid, e in grp["events"].items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=None, help="PX4 build: main, or the default (1.15)")
    ap.add_argument("--speedup", type=float, default=5.0)
    a = ap.parse_args()
    table = events_table(a.build)
    work = Path(tempfile.mkdtemp(prefix="px4-mission-events-"))
    sitl = start_claimed("px4", a.speedup, build=a.build, workdir=work / "sitl")
    try:
        sitl.set_param("COM_RCL_EXCEPT", 4, int32=True)
        v = Vehicle.connect(Endpoint("udp", "127.0.0.1", sitl.udp_port), "px4-copter", timeout=30)
        boot = [0]
        mode = [None]

        def say(text: str) -> None:
            print(f"{boot[0] / 1000:9.3f} {text}", flush=True)

        def on_msg(m) -> None:
            t = m.get_type()
            if hasattr(m, "time_boot_ms"):
                boot[0] = m.time_boot_ms
            if t == "STATUSTEXT":
                say(f"STATUSTEXT {m.severity} {m.text}")
            elif t == "UNKNOWN_410":
                buf = bytes(m.data)[10:]  # MAVLink 2 header; the payload's trailing zeros may be cut
                buf = (buf + bytes(60))[:53]
                eid, tms, seq = struct.unpack("<IIH", buf[:10])
                args = buf[13:53]
                text = table.get(eid & 0xFFFFFF, "?")
                say(f"EVENT {eid >> 24}:{eid & 0xFFFFFF} t={tms} {text} args={args[:8].hex()}")
            elif t == "MISSION_CURRENT":
                key = (m.seq, getattr(m, "total", None), getattr(m, "mission_state", None))
                if getattr(on_msg, "last_mc", None) != key:
                    on_msg.last_mc = key
                    say(f"MISSION_CURRENT seq {key[0]} total {key[1]} state {key[2]}")
            elif t == "HEARTBEAT" and v.link.is_vehicle(m):
                name = v.stack.mode_name(m.custom_mode)
                if name != mode[0]:
                    mode[0] = name
                    say(f"mode {name}")
            elif t in ("MISSION_ACK", "MISSION_ITEM_REACHED", "COMMAND_ACK"):
                say(f"{t} {m.to_dict()}")

        v.link.handlers.append(on_msg)
        v.setup_streams()
        mon = Monitor(limits_from_profile(v.profile), v.stack.modes["guided"], v.stack.mode_name)
        v.ensure_airborne()
        spec = ManoeuvreSpec.from_dict("auto_mission", {}).quick()
        f = fly_manoeuvre(v, spec, mon, gains_label="baseline", tlog_path=work / "auto.tlog", log=print)
        print("outcome", f.outcome.value, f.message, {k: round(x, 3) for k, x in f.metrics.items()})
        v.land()
        v.close()
    finally:
        sitl.stop()
        release_stopped()
        print("work", work)


if __name__ == "__main__":
    main()
