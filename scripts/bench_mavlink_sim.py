"""Benchmark of the MAVLink simulator: a 12 s figure-8 flown over real UDP in lockstep.

The simulator runs in its own process (`python -m ksbo_sim.mavlink --lockstep`); the client here is a lean
pymavlink one (dialect parser on a plain UDP socket, no mavutil) that streams one pos+vel+acc setpoint per
control step and waits for the step's LOCAL_POSITION_NED, ATTITUDE and ACTUATOR_OUTPUT_STATUS (all at 50 Hz).
Reports the real-time factor (12 s / wall time of the 600-step flight), telemetry messages per wall second,
and the flight's P(a) next to the in-process value. Usage: python scripts/bench_mavlink_sim.py [--runs N] [--no-write]
"""

from __future__ import annotations

import argparse
import os
import select
import socket
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mavlink

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench_common import machine, write_result  # noqa: E402

from ksbo_mav.profiles import load_profile  # noqa: E402
from ksbo_mav.scoring import score, score_rollout  # noqa: E402
from ksbo_sim import EpisodeConfig, simulate  # noqa: E402

WANT = ("LOCAL_POSITION_NED", "ATTITUDE", "ACTUATOR_OUTPUT_STATUS")


class Lean:
    def __init__(self, port: int) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
        self.sock.connect(("127.0.0.1", port))
        self.mav = mavlink.MAVLink(self, srcSystem=255, srcComponent=190)
        self.parser = mavlink.MAVLink(None)
        self.parser.robust_parsing = True
        self.received = 0

    def write(self, buf: bytes) -> None:
        self.sock.send(buf)

    def messages(self, timeout: float):
        ready, _, _ = select.select([self.sock], [], [], timeout)
        if not ready:
            return []
        msgs = self.parser.parse_buffer(self.sock.recv(65535)) or []
        self.received += len(msgs)
        return msgs

    def wait(self, kind: str, cond=lambda m: True, timeout: float = 30.0):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for m in self.messages(0.5):
                if m.get_type() == kind and cond(m):
                    return m
        raise TimeoutError(kind)

    def command(self, cmd: int, *p: float) -> int:
        self.mav.command_long_send(1, 1, cmd, 0, *(list(p) + [0.0] * (7 - len(p))))
        return self.wait("COMMAND_ACK", lambda m: m.command == cmd).result


def _cpu_s(pid: int) -> float:
    """User + system CPU seconds of a process (Linux /proc; 10 ms ticks, so sum over several flights)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def fly(cli: Lean, refs: np.ndarray, steps: int) -> tuple[float, int, np.ndarray, np.ndarray]:
    states, thrust = np.empty((steps, 6)), np.empty((steps, 2))
    before = cli.received
    t0 = time.perf_counter()
    t_prev = -1
    for k in range(steps):
        r = refs[k]
        cli.mav.set_position_target_local_ned_send(0, 1, 1, 1, 0x0C00, r[0], 0.0, -r[2], r[1], 0.0, -r[3],
                                                   0.0, 0.0, 0.0, 0.0, 0.0)
        got = {}
        while len(got) < 3:
            for m in cli.messages(5.0):
                kind = m.get_type()
                if kind in WANT:
                    t = m.time_usec // 1000 if kind == "ACTUATOR_OUTPUT_STATUS" else m.time_boot_ms
                    if t > t_prev:
                        got[kind] = m
        lp, at, ac = got["LOCAL_POSITION_NED"], got["ATTITUDE"], got["ACTUATOR_OUTPUT_STATUS"]
        t_prev = lp.time_boot_ms
        states[k] = (lp.x, lp.vx, -lp.z, -lp.vz, -at.pitch, -at.pitchspeed)
        thrust[k] = ac.actuator[:2]
    return time.perf_counter() - t0, cli.received - before, states, thrust


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--no-write", action="store_true",
                    help="print only, do not write benchmarks/mavlink-sim/results.md")
    args = ap.parse_args()
    cfg = EpisodeConfig()
    refs = cfg.reference()
    sim = subprocess.Popen([sys.executable, "-m", "ksbo_sim.mavlink", "--udp", "127.0.0.1:0", "--lockstep"],
                           stdout=subprocess.PIPE, text=True)
    try:
        port = int(sim.stdout.readline().split()[2].rsplit(":", 1)[1])
        cli = Lean(port)
        cli.mav.heartbeat_send(6, 8, 0, 0, 0)
        cli.wait("HEARTBEAT")
        assert cli.command(176, 1, 4) == 0 and cli.command(400, 1) == 0 and cli.command(22, *[0] * 6, 1.0) == 0
        for mid in (30, 32, 375):
            assert cli.command(511, mid, 20000) == 0
        assert cli.command(31011, 4.0) == 0
        walls, rates, Ps = [], [], []
        cpu_sim0, cpu_cli0 = _cpu_s(sim.pid), time.process_time()
        for _ in range(args.runs):
            assert cli.command(31010, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0) == 0
            wall, n_msgs, states, thrust = fly(cli, refs, cfg.steps)
            walls.append(wall)
            rates.append(n_msgs / wall)
            Ps.append(score(states, refs[1:], np.arange(cfg.steps), cfg.steps, thrust).P[0])
        # Includes the 600-step scoring of each flight on the client side and the set-state commands.
        cpu_sim = (_cpu_s(sim.pid) - cpu_sim0) / args.runs
        cpu_cli = (time.process_time() - cpu_cli0) / args.runs
    finally:
        sim.terminate()
        sim.wait(10)
    P_ref = score_rollout(simulate(load_profile("sim-planar").default, np.array([0, 0, 1.0, 0, 0, 0]))).P[0]
    secs = cfg.steps * cfg.dt
    med = statistics.median(walls)
    load = open("/proc/loadavg").read().split()[0] if Path("/proc/loadavg").exists() else "?"
    body = f"""Machine: {machine()}. Script: `python scripts/bench_mavlink_sim.py` (load average at the end: {load}).
Goal: a 12 s figure-8 over MAVLink in lockstep at >= 50x real time on 2 cores, client and simulator both running.

Simulator process `python -m ksbo_sim.mavlink --lockstep` on UDP 127.0.0.1; lean pymavlink client (dialect parser on
a socket) streaming one pos+vel+acc setpoint per 20 ms control step and waiting for that step's
LOCAL_POSITION_NED + ATTITUDE + ACTUATOR_OUTPUT_STATUS (50 Hz each, plus 1 Hz/10 Hz housekeeping streams).
{args.runs} flights of {cfg.steps} steps ({secs:g} s simulated) from the figure-8 origin, default gains.

| quantity | value |
|---|---|
| wall time per 12 s flight, median (min, max) | {med * 1e3:.0f} ms ({min(walls) * 1e3:.0f}, {max(walls) * 1e3:.0f}) |
| real-time factor, median (best) | {secs / med:.1f}x ({secs / min(walls):.1f}x) |
| round trip per control step, median | {med / cfg.steps * 1e6:.0f} us |
| CPU per flight: simulator + client (load-independent) | {cpu_sim * 1e3:.0f} ms + {cpu_cli * 1e3:.0f} ms |
| real-time factor if the two processes had the cores to themselves, 12 s / CPU | {secs / (cpu_sim + cpu_cli):.0f}x |
| telemetry received, median | {statistics.median(rates):,.0f} messages/s wall |
| P(a) of the flights (float32 wire) vs in-process `simulate` | {min(Ps):.6f}..{max(Ps):.6f} vs {P_ref:.6f} |
"""
    print(body)
    if not args.no_write:
        write_result("mavlink-sim", body)
    return 0


if __name__ == "__main__":
    sys.exit(main())
