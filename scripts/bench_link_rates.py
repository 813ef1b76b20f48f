"""Benchmark: does the figure-8 need 50 Hz from the ground? The same gains flown at 50 Hz and at 10 Hz.

For each stack (ArduCopter SITL at -s 10, PX4 SITL at -s 5): a one-trial `ksbo-mav tune` campaign takes off and
snapshots the default gains; then the default gains are flown ``--reps`` times at each rate, the rates
alternating (50, 10, 50, 10, ...) so that a slow change of the vehicle hits both alike. A rate is the profile's
`[mission] rate_hz`, which sets both the setpoint stream (SET_POSITION_TARGET_LOCAL_NED with velocity and
acceleration feed-forward, type_mask 0x0C00, so the autopilot's own controller fills in between setpoints) and
the telemetry asked for (LOCAL_POSITION_NED and ATTITUDE by SET_MESSAGE_INTERVAL). Each flight is the tuner's own
MavlinkObjective (same mission, monitor and restore); the lap-2 RMS is against the analytic figure-8 at the
flight's own telemetry samples.

    python scripts/bench_link_rates.py [--reps 3] [--rates 50 10] [--stacks ardupilot px4] [--no-write]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench_common import SPEED, endpoint, machine, write_result  # noqa: E402

from ksbo_mav.mav.objective import MavlinkObjective  # noqa: E402
from ksbo_mav.mav.params import load_snapshot  # noqa: E402
from ksbo_mav.mav.vehicle import Vehicle  # noqa: E402
from ksbo_sim.sitl import start_sitl  # noqa: E402

PROFILE = {"ardupilot": "ardupilot-copter", "px4": "px4-copter"}


def profile_at(kind: str, rate: int, work: Path) -> Path:
    """A copy of the stack's shipped profile with ``[mission] rate_hz = rate``."""
    import ksbo_params

    text = (Path(ksbo_params.__file__).parent / f"{PROFILE[kind]}.toml").read_text()
    text, n = re.subn(r"(?m)^rate_hz = \d+", f"rate_hz = {rate}", text)
    assert n == 1, "the profile's [mission] rate_hz line was not found"
    path = work / f"{PROFILE[kind]}-{rate}hz.toml"
    path.write_text(text)
    return path


def run_stack(kind: str, rates: list[int], reps: int, instance: int, speedup: float) -> dict:
    work = Path(tempfile.mkdtemp(prefix=f"bench-rates-{kind}-"))
    sitl = start_sitl(kind, instance=instance, speedup=speedup, workdir=work / "sitl")
    out: dict[int, list] = {r: [] for r in rates}
    try:
        if kind == "px4":
            sitl.set_param("COM_RCL_EXCEPT", 4, int32=True)  # no RC in SITL: allow OFFBOARD without it
        args, ep = endpoint(sitl)
        d = work / "campaign"
        subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), *args, "--budget", "1", "--prior",
                        "none", "--confirm", "0", "--end", "hold", "--json"],
                       capture_output=True, text=True, timeout=1800, check=True)
        snap = load_snapshot(d)
        base = snap.baseline()
        profiles = {r: profile_at(kind, r, work) for r in rates}
        for k in range(reps):
            for r in rates:
                v = Vehicle.connect(ep, str(profiles[r]))
                try:
                    v.setup_streams()
                    obj = MavlinkObjective(v, base, d / f"flights-{r}hz", first_index=k)
                    f = obj.fly(v.gain_map.from_params(base), label=f"{r}hz")
                    out[r].append({"rms_lap2_m": f.score.get("rms_lap2_m"), "outcome": str(f.outcome)})
                    print(json.dumps({"stack": kind, "rate_hz": r, "rep": k, **out[r][-1]}), flush=True)
                    if k == reps - 1 and r == rates[-1]:
                        v.land()
                finally:
                    v.close()
    finally:
        sitl.stop()
    return {"stack": kind, "flights": out}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--reps", type=int, default=3, help="flights per rate (default 3)")
    ap.add_argument("--rates", type=int, nargs="+", default=[50, 10], help="setpoint = telemetry rates (Hz)")
    ap.add_argument("--stacks", nargs="+", default=["ardupilot", "px4"], choices=sorted(PROFILE))
    ap.add_argument("--speedup", type=float, default=None,
                    help="SITL speed-up for every stack (default: ArduCopter 10, PX4 5); a real vehicle flies at 1")
    ap.add_argument("--no-write", action="store_true", help="print only, do not write results.md")
    a = ap.parse_args()
    load0 = os.getloadavg()[0]
    speed = {k: a.speedup or SPEED[k] for k in a.stacks}
    results = [run_stack(kind, a.rates, a.reps, 6 + i, speed[kind]) for i, kind in enumerate(a.stacks)]
    ref = a.rates[0]
    rows = ["| stack | rate (Hz) | lap-2 RMS per flight (m) | mean (m) | vs " + f"{ref} Hz | outcomes |",
            "|---|---|---|---|---|---|"]
    for res in results:
        means = {}
        for r, fl in res["flights"].items():
            v = [x["rms_lap2_m"] for x in fl if x["rms_lap2_m"] is not None]
            means[r] = statistics.mean(v) if v else float("nan")
            rel = "" if r == ref else f"{100 * (means[r] / means[ref] - 1):+.1f} %"
            outs = ", ".join(sorted({x["outcome"] for x in fl}))
            rows.append(f"| {res['stack']} | {r} | {', '.join(f'{x:.3f}' for x in v)} | {means[r]:.3f} | {rel} | "
                        f"{outs} |")
    body = f"""Machine: {machine()}. Script: `python scripts/bench_link_rates.py --reps {a.reps} --rates \
{' '.join(map(str, a.rates))}{f' --speedup {a.speedup:g}' if a.speedup else ''} --stacks {' '.join(a.stacks)}`.

## The same gains at 50 Hz and at 10 Hz (setpoints and telemetry)

The default gains of each stack's profile, flown {a.reps} times at each rate, alternating, on one SITL per stack
({', '.join(f"{k} SITL at -s {v:g}" for k, v in speed.items())}); setpoints carry velocity and
acceleration feed-forward. Lap-2 RMS against the analytic figure-8 at the flight's own telemetry samples. 1-min load
{load0:.1f} at the start, {os.getloadavg()[0]:.1f} at the end.

{chr(10).join(rows)}
"""
    print(body)
    if not a.no_write:
        write_result("link-rates", body)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
