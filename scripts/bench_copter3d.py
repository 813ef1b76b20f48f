"""Benchmark of the JSBSim 3-D copter: real-time factor and figure-8 tracking vs gains.

* Real-time factor of a 40 s (2-lap) horizontal figure-8 flown in process (goal >= 20x), per personality, and
  the same flight over MAVLink in lockstep through `python -m ksbo_sim.mavlink --vehicle copter3d` (client and
  simulator both running on this machine).
* Lap-2 RMS tracking error for default and varied gains, in the layout of the fact sheet's section 8 table
  (ArduCopter SITL 4.7.0-dev values quoted for comparison), for the x-y mission and the x-z variant.

Writes benchmarks/copter3d/results.md.

    python scripts/bench_copter3d.py [--no-write] [--no-mavlink]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench_common import machine, write_result  # noqa: E402

from ksbo_sim.copter3d import Copter3D, fly  # noqa: E402
from ksbo_sim.copter3d.mission import tracking_rms  # noqa: E402
from ksbo_task.figure8_ne import Figure8H  # noqa: E402

#: (parameter, value, SITL lap-2 RMS on the affected axis from the fact sheet, axis index) for the x-z variant.
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


def rtf_in_process(personality: str, repeats: int = 3) -> tuple[float, float]:
    """(best wall seconds for the 40 s flight, its CPU seconds, lap-2 RMS)."""
    v = Copter3D(personality)
    best, best_cpu, rms = np.inf, np.inf, np.nan
    for _ in range(repeats):
        t, c = time.perf_counter(), time.process_time()
        f = fly(v, Figure8H())
        best = min(best, time.perf_counter() - t)
        best_cpu = min(best_cpu, time.process_time() - c)
        rms = f.rms_lap2
    return best, best_cpu, rms


def _cpu_seconds(pid: int) -> float:
    """user + system CPU seconds of a process (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def rtf_mavlink(personality: str) -> tuple[float, float, float, float]:
    """(wall s for the 40 s stream, lap-2 RMS from LOCAL_POSITION_NED, LOCAL_POSITION_NED per wall s,
    CPU s of simulator + client for the stream: the load-independent cost)."""
    from ksbo_sim.testing import GUIDED, MASK_POS, running_sim  # plain pymavlink client of the tests

    fig = Figure8H()
    with running_sim("--lockstep", "--vehicle", "copter3d", "--personality", personality) as (sim, cli):
        cli.hello()
        if personality == "px4":
            assert cli.command(176, 1, 6, 0) == 0  # OFFBOARD (main 6)
        else:
            assert cli.command(176, 1, GUIDED) == 0
        assert cli.command(400, 1) == 0
        assert cli.command(22, 0, 0, 0, 0, 0, 0, fig.altitude) == 0
        assert cli.interval(32, 50) == 0
        assert cli.step(25.0) == 0
        if personality == "px4":
            assert cli.command(176, 1, 6, 0) == 0  # back to OFFBOARD after AUTO.TAKEOFF -> hold
        cli.setpoint(tuple(fig.start()), mask=MASK_POS)
        assert cli.step(5.0) == 0
        cli.drain()
        t0 = cli.last["LOCAL_POSITION_NED"].time_boot_ms
        times, pos = [], []
        cpu = _cpu_seconds(sim.proc.pid) + time.process_time()
        wall = time.perf_counter()
        for tk in fig.sample_times():
            cli.setpoint(tuple(fig.position(tk)), tuple(fig.velocity(tk)), tuple(fig.acceleration(tk)))
            m = cli.recv("LOCAL_POSITION_NED", 5.0, lambda m: m.time_boot_ms > (t0 + tk * 1000 + 1))
            if m is None:
                raise TimeoutError("no telemetry for a setpoint")
            times.append((m.time_boot_ms - t0) / 1000.0)
            pos.append((m.x, m.y, m.z))
        wall = time.perf_counter() - wall
        cpu = _cpu_seconds(sim.proc.pid) + time.process_time() - cpu
    t, p = np.array(times), np.array(pos)
    return wall, tracking_rms(t, p, fig, fig.duration - fig.period, fig.duration), len(times) / wall, cpu


def gain_table(second_axis: int) -> list[str]:
    v = Copter3D("ardupilot-legacy")
    fig = Figure8H(second_axis=second_axis)
    rows = []
    # The horizontal mission holds altitude, so the Z-gain rows only mean something in the x-z variant.
    cases = SITL_XZ if second_axis == 2 else [c for c in SITL_XZ if c[3] in (None, 0)]
    for name, value, sitl, _ in cases:
        if name is not None:
            default = v.get_param(name)
            v.set_param(name, value)
        f = fly(v, fig)
        if name is not None:
            v.set_param(name, default)
        x, y, z = f.rms_lap2_axes
        label = "defaults" if name is None else f"`{name}` {default:g} -> {value:g}"
        rows.append(f"| {label} | {f.rms_lap2:.3f} | {x:.3f} / {y:.3f} / {z:.3f} | {f.rms_all:.2f} | "
                    f"{f.max_error:.2f} | {f.max_tilt_deg:.1f} | {sitl if second_axis == 2 else ''} |")
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-write", action="store_true", help="print only, do not write benchmarks/copter3d/results.md")
    ap.add_argument("--no-mavlink", action="store_true", help="skip the lockstep MAVLink flights")
    args = ap.parse_args()

    load = os.getloadavg()[0]
    lines = [f"Machine: {machine()}; 1-min load average at start {load:.1f} (the 2 cores are shared: timings scale "
             "with it). Script: `python scripts/bench_copter3d.py`.",
             "Vehicle: JSBSim 1.3.3 F450 (wheel files + linear rotor drag 0.3 /s, see `sim/copter3d/vehicle.py`), "
             "physics 2.5 ms, position/attitude/rate loops every physics step (400 Hz), 50 Hz setpoints.",
             "Goal: 3-D figure-8 in lockstep >= 20x real time.", "",
             "| flight (40 s, 2 laps, x-y figure-8) | wall | real-time factor | lap-2 RMS (m) |", "|---|---|---|---|"]
    for pers in ("ardupilot", "ardupilot-legacy", "px4"):
        wall, cpu, rms = rtf_in_process(pers)
        lines.append(f"| in process, `{pers}` (best of 3; CPU {cpu:.2f} s = {40.0 / cpu:.0f}x) | {wall:.2f} s | "
                     f"{40.0 / wall:.0f}x | {rms:.3f} |")
        print(lines[-1], flush=True)
    if not args.no_mavlink:
        for pers in ("ardupilot-legacy", "px4"):
            wall, rms, rate, cpu = rtf_mavlink(pers)
            lines.append(f"| MAVLink lockstep, `{pers}`, client + simulator processes | {wall:.2f} s | "
                         f"{40.0 / wall:.0f}x | {rms:.3f} |")
            lines.append(f"| same, CPU time simulator + client (load-independent: 40 s / CPU) | {cpu:.2f} s | "
                         f"{40.0 / cpu:.0f}x | |")
            print(lines[-1], f"telemetry {rate:.0f} LOCAL_POSITION_NED/s wall", flush=True)
    # Stock files (no rotor drag), for the record of why the drag term is there.
    f0 = fly(Copter3D("ardupilot-legacy", rotor_drag=0.0), Figure8H())
    lines += ["", f"Stock F450 files without the rotor-drag term: lap-2 RMS {f0.rms_lap2:.3f} m at default gains "
              "(ten times below SITL; hence the calibrated drag).", ""]
    head = ["| gains (`ardupilot-legacy` names) | lap-2 RMS (m) | lap-2 x / y / z (m) | RMS all (m) | "
            "max error (m) | max tilt (deg) | SITL lap 2 (fact sheet 8) |", "|---|---|---|---|---|---|---|"]
    for axis, title in ((1, "x-y figure-8 (the mission: north 10 sin wt, east 2.5 sin 2wt, 10 m up)"),
                        (2, "x-z variant (second term on down), as in the fact sheet's gain table")):
        lines += [f"{title}:", "", *head, *gain_table(axis), ""]
    lines.append("SITL reference at default gains, x-y pos+vel+acc: lap-2 0.234 m (x 0.199, y 0.123); "
                 "4 repeats 0.205-0.235 m.")
    lines.append(f"1-min load average at the end: {os.getloadavg()[0]:.1f}.")
    body = "\n".join(lines)
    print(body)
    if not args.no_write:
        write_result("copter3d", body)


if __name__ == "__main__":
    main()
