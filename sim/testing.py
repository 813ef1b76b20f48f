"""Helpers for tests and benchmarks of the MAVLink simulator: a plain pymavlink ground station (MAVLink 2 over
127.0.0.1) that talks to a :class:`~ksbo_sim.process.SimProcess`, a lockstep figure-8 flight, and the ids the
tests use. Independent of the tuner (``ksbo_sim`` never imports ``ksbo_mav``).

Importing this module sets ``MAVLINK20=1`` (pymavlink reads it when ``mavutil`` is first imported).
"""

from __future__ import annotations

import os

os.environ["MAVLINK20"] = "1"  # before pymavlink.mavutil is imported, else MAVLink 1 (fact sheet 5.2)

import socket  # noqa: E402
import time  # noqa: E402
from contextlib import contextmanager  # noqa: E402

import numpy as np  # noqa: E402
from pymavlink import mavutil  # noqa: E402

from ksbo_sim.process import SimProcess, free_udp_port  # noqa: E402

__all__ = ["CMD_SIM_SET_STATE", "CMD_SIM_STEP", "CMD_SIM_RESET", "GUIDED", "LOITER", "LAND", "MASK_POS_VEL_ACC",
           "MASK_POS", "Client", "SimProcess", "fly_figure8", "free_udp_port", "read_params", "running_sim"]

CMD_SIM_SET_STATE, CMD_SIM_STEP, CMD_SIM_RESET = 31010, 31011, 31012
GUIDED, LOITER, LAND = 4, 5, 9
MASK_POS_VEL_ACC = 0x0C00
MASK_POS = 0x0DF8


class Client:
    """A plain pymavlink ground station (sysid 255) that talks first, so the UDP simulator learns its address."""

    def __init__(self, sim: SimProcess, source_system: int = 255) -> None:
        url = f"udpout:{sim.host}:{sim.port}" if sim.kind == "udp" else f"tcp:{sim.host}:{sim.port}"
        self.conn = mavutil.mavlink_connection(url, source_system=source_system, source_component=190)
        # Lockstep steps of several seconds arrive as one burst (10 s x 3 streams x 50 Hz = 1500 messages).
        self.conn.port.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
        self.mav = self.conn.mav
        self.texts: list[str] = []
        self.last: dict = {}

    def close(self) -> None:
        self.conn.close()

    def hello(self, timeout: float = 10.0):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            self.mav.heartbeat_send(6, 8, 0, 0, 0)
            hb = self.recv("HEARTBEAT", 1.0)
            if hb is not None:
                return hb
        raise TimeoutError("no HEARTBEAT from the simulator")

    def recv(self, kind, timeout: float = 5.0, cond=None):
        """Next message of ``kind`` (str or list) satisfying ``cond``; every message read is remembered in
        ``self.last`` (by type) and STATUSTEXTs in ``self.texts``."""
        kinds = {kind} if isinstance(kind, str) else set(kind)
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            m = self.conn.recv_match(blocking=True, timeout=min(left, 0.5))
            if m is None:
                continue
            self._note(m)
            if m.get_type() in kinds and (cond is None or cond(m)):
                return m

    def _note(self, m) -> None:
        self.last[m.get_type()] = m
        if m.get_type() == "STATUSTEXT":
            self.texts.append(m.text)

    def drain(self) -> None:
        """Read everything already received (kept in ``last`` / ``texts``)."""
        while (m := self.conn.recv_match(blocking=False)) is not None:
            self._note(m)

    def command(self, cmd: int, *params: float, timeout: float = 5.0):
        p = list(params) + [0.0] * (7 - len(params))
        self.mav.command_long_send(1, 1, cmd, 0, *p)
        ack = self.recv("COMMAND_ACK", timeout, lambda m: m.command == cmd)
        if ack is None:
            raise TimeoutError(f"no COMMAND_ACK for {cmd}")
        return ack.result

    def param_set(self, name: str, value: float, ptype: int = 9, timeout: float = 3.0):
        self.mav.param_set_send(1, 1, name.encode(), value, ptype)
        return self.recv("PARAM_VALUE", timeout, lambda m: m.param_id == name)

    def param_read(self, name: str, timeout: float = 3.0):
        self.mav.param_request_read_send(1, 1, name.encode(), -1)
        return self.recv("PARAM_VALUE", timeout, lambda m: m.param_id == name)

    def interval(self, msg_id: int, hz: float) -> int:
        return self.command(511, msg_id, 1e6 / hz)

    def step(self, seconds: float) -> int:
        return self.command(CMD_SIM_STEP, seconds, timeout=30.0)

    def setpoint(self, pos, vel=(0, 0, 0), acc=(0, 0, 0), mask: int = MASK_POS_VEL_ACC) -> None:
        self.mav.set_position_target_local_ned_send(0, 1, 1, 1, mask, *pos, *vel, *acc, 0, 0)


def fly_figure8(cli: Client, refs: np.ndarray, steps: int) -> dict[str, np.ndarray]:
    """Lockstep figure-8: send setpoint k (reference at t = k dt, NED), wait for the step's telemetry.

    Returns per-step arrays: planar states (x, vx, z, vz, theta, theta_dot) after step k and pair thrusts.
    """
    states = np.full((steps, 6), np.nan)
    thrust = np.full((steps, 2), np.nan)
    t_prev = None
    for k in range(steps):
        r = refs[k]
        cli.setpoint((r[0], 0.0, -r[2]), (r[1], 0.0, -r[3]), (0.0, 0.0, 0.0))
        want = {"LOCAL_POSITION_NED", "ATTITUDE", "ACTUATOR_OUTPUT_STATUS"}
        got = {}
        deadline = time.monotonic() + 5.0
        while want - got.keys() and time.monotonic() < deadline:
            m = cli.conn.recv_match(blocking=True, timeout=1.0)
            if m is None:
                continue
            cli._note(m)
            if m.get_type() not in want:
                continue
            t_ms = m.time_usec // 1000 if m.get_type() == "ACTUATOR_OUTPUT_STATUS" else m.time_boot_ms
            if t_prev is None or t_ms > t_prev:
                got[m.get_type()] = m
        if want - got.keys():
            raise TimeoutError(f"step {k}: missing {want - got.keys()}")
        t_prev = got["LOCAL_POSITION_NED"].time_boot_ms
        lp, at, ac = got["LOCAL_POSITION_NED"], got["ATTITUDE"], got["ACTUATOR_OUTPUT_STATUS"]
        states[k] = (lp.x, lp.vx, -lp.z, -lp.vz, -at.pitch, -at.pitchspeed)
        thrust[k] = ac.actuator[:2]
    return {"states": states, "thrust": thrust}


@contextmanager
def running_sim(*args: str, kind: str = "udp"):
    sim = SimProcess(*args, kind=kind)
    cli = Client(sim)
    try:
        yield sim, cli
    finally:
        cli.close()
        sim.stop()


def read_params(sim: SimProcess, names, timeout: float = 10.0) -> dict[str, float]:
    """Read parameters over a new, independent plain-pymavlink connection (talks first to the simulator's own
    port, so it also works while the simulator streams to another ground station)."""
    cli = Client(sim, source_system=250)
    try:
        cli.hello(timeout)
        out = {}
        for name in names:
            for _ in range(8):
                m = cli.param_read(name, timeout=1.0)
                if m is not None:
                    out[name] = float(m.param_value)
                    break
            else:
                raise TimeoutError(f"no PARAM_VALUE for {name}")
        return out
    finally:
        cli.close()
