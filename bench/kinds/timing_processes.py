"""Timings of whole processes, measured by themselves (the ``timing`` kind's :data:`MEASURES`): a simulator in its
own process and a client over MAVLink on loopback, in lockstep, and the scoring of a 500 MB flight log
(ksbo_bench.kinds.timing_logs). Wall time depends on the machine's load; the CPU seconds of the processes do not
(each record keeps both, and the 1-min load average at its end).

- ``planar-mavlink-flight`` (``runs``, default 5): our planar simulator (`python -m ksbo_sim.mavlink --lockstep`)
  and a lean pymavlink client (dialect parser on a plain UDP socket) streaming one pos+vel+acc setpoint per 20 ms
  control step and waiting for that step's LOCAL_POSITION_NED, ATTITUDE and ACTUATOR_OUTPUT_STATUS: a 12 s
  figure-8 from its origin at the default gains; its P next to the in-process value;
- ``copter3d-mavlink-flight`` (``personality``): our JSBSim copter in lockstep flying a 40 s (2-lap) figure-8
  from a plain pymavlink client (ksbo_sim.testing);
- ``score-big-log`` (``size_mb``, default 500): ksbo_bench.kinds.timing_logs (needs an ArduCopter SITL).
"""

from __future__ import annotations

import os
import select
import socket
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

WANT = ("LOCAL_POSITION_NED", "ATTITUDE", "ACTUATOR_OUTPUT_STATUS")


def cpu_seconds(pid: int) -> float:
    """User + system CPU seconds of a process (Linux /proc; 10 ms ticks: sum over several flights)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


class Lean:
    """A lean MAVLink client: the dialect's parser on a connected UDP socket."""

    def __init__(self, port: int) -> None:
        from pymavlink.dialects.v20 import ardupilotmega as mavlink

        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
        self.sock.connect(("127.0.0.1", port))
        self.mav = mavlink.MAVLink(self, srcSystem=255, srcComponent=190)
        self.parser = mavlink.MAVLink(None)
        self.parser.robust_parsing = True
        self.received = 0

    def write(self, buf: bytes) -> None:
        self.sock.send(buf)

    def messages(self, timeout: float) -> list:
        ready, _, _ = select.select([self.sock], [], [], timeout)
        if not ready:
            return []
        msgs = self.parser.parse_buffer(self.sock.recv(65535)) or []
        self.received += len(msgs)
        return msgs

    def wait(self, kind: str, cond: Callable = lambda m: True, timeout: float = 30.0):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for m in self.messages(0.5):
                if m.get_type() == kind and cond(m):
                    return m
        raise TimeoutError(kind)

    def command(self, cmd: int, *p: float) -> int:
        self.mav.command_long_send(1, 1, cmd, 0, *(list(p) + [0.0] * (7 - len(p))))
        return self.wait("COMMAND_ACK", lambda m: m.command == cmd).result


def _fly_planar(cli: Lean, refs: np.ndarray, steps: int) -> tuple[float, int, np.ndarray, np.ndarray]:
    states, thrust = np.empty((steps, 6)), np.empty((steps, 2))
    before, t0, t_prev = cli.received, time.perf_counter(), -1
    for k in range(steps):
        r = refs[k]
        cli.mav.set_position_target_local_ned_send(0, 1, 1, 1, 0x0C00, r[0], 0.0, -r[2], r[1], 0.0, -r[3],
                                                   0.0, 0.0, 0.0, 0.0, 0.0)
        got: dict[str, Any] = {}
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


def planar_mavlink_flight(key: dict[str, Any]) -> dict[str, Any]:
    from ksbo_mav.profiles import load_profile
    from ksbo_mav.scoring import score, score_rollout
    from ksbo_sim import EpisodeConfig, simulate

    runs, cfg = int(key.get("runs", 5)), EpisodeConfig()
    refs = cfg.reference()
    sim = subprocess.Popen([sys.executable, "-m", "ksbo_sim.mavlink", "--udp", "127.0.0.1:0", "--lockstep"],
                           stdout=subprocess.PIPE, text=True)
    try:
        cli = Lean(int(sim.stdout.readline().split()[2].rsplit(":", 1)[1]))
        cli.mav.heartbeat_send(6, 8, 0, 0, 0)
        cli.wait("HEARTBEAT")
        assert cli.command(176, 1, 4) == 0 and cli.command(400, 1) == 0 and cli.command(22, *[0] * 6, 1.0) == 0
        for mid in (30, 32, 375):
            assert cli.command(511, mid, 20000) == 0
        assert cli.command(31011, 4.0) == 0
        walls, rates, Ps = [], [], []
        cpu_sim0, cpu_cli0 = cpu_seconds(sim.pid), time.process_time()
        for _ in range(runs):
            assert cli.command(31010, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0) == 0
            wall, n_msgs, states, thrust = _fly_planar(cli, refs, cfg.steps)
            walls.append(wall)
            rates.append(n_msgs / wall)
            Ps.append(float(score(states, refs[1:], np.arange(cfg.steps), cfg.steps, thrust).P[0]))
        cpu_sim, cpu_cli = (cpu_seconds(sim.pid) - cpu_sim0) / runs, (time.process_time() - cpu_cli0) / runs
    finally:
        sim.terminate()
        sim.wait(10)
    P_ref = float(score_rollout(simulate(load_profile("sim-planar").default, np.array([0, 0, 1.0, 0, 0, 0]))).P[0])
    secs, med = cfg.steps * cfg.dt, statistics.median(walls)
    return {"result": {"sim_s": secs, "steps": cfg.steps, "runs": runs, "P_min": min(Ps), "P_max": max(Ps),
                       "P_inprocess": P_ref},
            "timing": {"seconds": min(walls), "median_s": med, "max_s": max(walls), "real_time_factor": secs / med,
                       "real_time_factor_best": secs / min(walls), "round_trip_us": med / cfg.steps * 1e6,
                       "cpu_sim_s": cpu_sim, "cpu_client_s": cpu_cli,
                       "real_time_factor_cpu": secs / (cpu_sim + cpu_cli),
                       "messages_per_s": statistics.median(rates)}}


def copter3d_mavlink_flight(key: dict[str, Any]) -> dict[str, Any]:
    from ksbo_sim.copter3d.mission import tracking_rms
    from ksbo_sim.testing import GUIDED, MASK_POS, running_sim
    from ksbo_task.figure8_ne import Figure8H

    pers, fig = key.get("personality", "ardupilot-legacy"), Figure8H()
    with running_sim("--lockstep", "--vehicle", "copter3d", "--personality", pers) as (sim, cli):
        cli.hello()
        mode = (176, 1, 6, 0) if pers == "px4" else (176, 1, GUIDED)  # OFFBOARD (main 6) or GUIDED
        assert cli.command(*mode) == 0 and cli.command(400, 1) == 0
        assert cli.command(22, 0, 0, 0, 0, 0, 0, fig.altitude) == 0 and cli.interval(32, 50) == 0
        assert cli.step(25.0) == 0
        if pers == "px4":
            assert cli.command(*mode) == 0  # back to OFFBOARD after AUTO.TAKEOFF -> hold
        cli.setpoint(tuple(fig.start()), mask=MASK_POS)
        assert cli.step(5.0) == 0
        cli.drain()
        t0 = cli.last["LOCAL_POSITION_NED"].time_boot_ms
        times, pos = [], []
        cpu, wall = cpu_seconds(sim.proc.pid) + time.process_time(), time.perf_counter()
        for tk in fig.sample_times():
            cli.setpoint(tuple(fig.position(tk)), tuple(fig.velocity(tk)), tuple(fig.acceleration(tk)))
            m = cli.recv("LOCAL_POSITION_NED", 5.0, lambda m: m.time_boot_ms > (t0 + tk * 1000 + 1))
            if m is None:
                raise TimeoutError("no telemetry for a setpoint")
            times.append((m.time_boot_ms - t0) / 1000.0)
            pos.append((m.x, m.y, m.z))
        wall = time.perf_counter() - wall
        cpu = cpu_seconds(sim.proc.pid) + time.process_time() - cpu
    rms = tracking_rms(np.array(times), np.array(pos), fig, fig.duration - fig.period, fig.duration)
    return {"result": {"sim_s": fig.duration, "rms_lap2": float(rms)},
            "timing": {"seconds": wall, "real_time_factor": fig.duration / wall, "cpu_s": cpu,
                       "real_time_factor_cpu": fig.duration / cpu, "messages_per_s": len(times) / wall}}


def _score_big_log(key: dict[str, Any]) -> dict[str, Any]:
    from ksbo_bench.kinds.timing_logs import score_big_log

    return score_big_log(key)


MEASURES: dict[str, Callable[[dict[str, Any]], dict[str, Any]]] = {
    "planar-mavlink-flight": planar_mavlink_flight, "copter3d-mavlink-flight": copter3d_mavlink_flight,
    "score-big-log": _score_big_log,
}
SITL_MEASURES = ("score-big-log",)
