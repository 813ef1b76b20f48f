"""Fly fixed gain sets on a fresh PX4 SITL and print each flight's lap-2 RMS (how the PX4 search
box was chosen: benchmarks/notes/plants.md).

A one-trial `ksbo-mav tune` campaign takes off and snapshots the defaults, then every variant (the defaults with
some gains replaced, by index into the profile's gain vector) is flown ``--reps`` times through the tuner's own
MavlinkObjective (same mission, monitor and restore), and the vehicle lands.

    python scripts/diag/sitl_fixed_gains.py '{"base": {}, "xyp1.89": {"0": 1.89}}' --reps 2 [--speedup 5]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # scripts/: _bench_common
from _bench_common import campaign_vehicle, endpoint  # noqa: E402

from ksbo_sim.sitl import start_sitl  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("variants", help='JSON {name: {gain index: value}}')
    ap.add_argument("--reps", type=int, default=2)
    ap.add_argument("--speedup", type=float, default=5.0)
    a = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="fixed-gains-"))
    sitl = start_sitl("px4", instance=8, speedup=a.speedup, workdir=work / "sitl")
    try:
        sitl.set_param("COM_RCL_EXCEPT", 4, int32=True)  # no RC in SITL: allow OFFBOARD without it
        args, _ = endpoint(sitl)
        d = work / "campaign"
        subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), *args, "--budget", "1", "--method",
                        "ksbo", "--prior", "none", "--confirm", "0", "--end", "hold", "--json"],
                       capture_output=True, text=True, timeout=1800, check=True)
        with campaign_vehicle(sitl, d, "fixed") as (obj, x0):
            for name, changes in json.loads(a.variants).items():
                x = x0.copy()
                for i, val in changes.items():
                    x[int(i)] = val
                flights = [obj.fly(x, label="fixed") for _ in range(a.reps)]
                print(json.dumps({"variant": name, "x": x.round(4).tolist(), "speedup": a.speedup,
                                  "rms_lap2_m": [f.score.get("rms_lap2_m") for f in flights],
                                  "outcome": [str(f.outcome) for f in flights]}), flush=True)
    finally:
        sitl.stop()


if __name__ == "__main__":
    main()
