"""PX4 SITL at 1x through the emulated radio: connect three times with an empty parameter cache and print how
the parameters came each time (the first by the PARAM protocol, then from the cache while PX4's _HASH_CHECK is
unchanged). The figures behind docs/links.md's parameter-cache paragraph.

    python scripts/diag/param_cache_radio.py [--shape SPEC] [--instance 4]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

os.environ["MAVLINK20"] = "1"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--shape", default="down=4000,up=2000,queue=1024,loss=0.05,latency=0.02,seed=1,radio=1")
    ap.add_argument("--instance", type=int, default=4)
    ap.add_argument("--connections", type=int, default=3)
    a = ap.parse_args()
    os.environ["KSBO_MAV_CACHE_DIR"] = tempfile.mkdtemp(prefix="ksbo-param-cache-")
    from ksbo_mav.mav.link import Endpoint
    from ksbo_mav.mav.vehicle import Vehicle
    from ksbo_sim.linkproc import LinkEmulator
    from ksbo_sim.process import free_udp_port
    from ksbo_sim.sitl import start_sitl

    sitl = start_sitl("px4", instance=a.instance, speedup=1.0)
    try:
        port = free_udp_port()
        emu = LinkEmulator(f"udpin:127.0.0.1:{sitl.radio_udp_port}", f"udp:127.0.0.1:{port}", a.shape)
        try:
            for k in range(a.connections):
                t0 = time.monotonic()
                v = Vehicle.connect(Endpoint("udp", "127.0.0.1", port), "px4-copter", timeout=30)
                dl = v.params.last_download
                print(f"connection {k + 1}: {len(v.params.table)} parameters, {dl.path}, {dl.seconds:.2f} s "
                      f"(connect {time.monotonic() - t0:.1f} s)", flush=True)
                v.close()
        finally:
            print("emulator:", emu.stop())
    finally:
        sitl.stop()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
