"""The onboard guard's tests, shared by the ArduCopter SITL and the built-in simulator: a second connection that
watches the vehicle, and the tuner stand-in (``guard_trial_process.py``) run as a process of its own so that its
link can be cut by killing it."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from ksbo_mav.mav.guard_script import GuardState

HERE = Path(__file__).resolve().parent


class Observer:
    """A second connection (``device``, pymavlink's notation) that reads what the vehicle does: its clock, mode,
    parameters, the guard's messages. Its system id (250) is not the one the guard watches."""

    def __init__(self, device: str) -> None:
        from pymavlink import mavutil

        self.conn = mavutil.mavlink_connection(device, source_system=250, source_component=190,
                                               autoreconnect=False)
        if device.startswith("udpout:"):  # a simulator answers whoever talked to it
            self.conn.mav.heartbeat_send(6, 8, 0, 0, 4)
        assert self.conn.wait_heartbeat(timeout=10) is not None
        self.conn.mav.command_long_send(1, 1, 511, 0, 2, 50_000, 0, 0, 0, 0, 0)  # SYSTEM_TIME at 20 Hz, this link
        self.vehicle_ms = 0
        self.mode = -1
        self.armed: bool | None = None
        self.texts: list[str] = []
        self.alive: list[tuple[int, float]] = []  # (time_boot_ms, KSG_ALIVE)

    def _take(self, m) -> None:
        if m.get_srcSystem() != 1:
            return
        t = m.get_type()
        if hasattr(m, "time_boot_ms"):
            self.vehicle_ms = max(self.vehicle_ms, int(m.time_boot_ms))
        if t == "HEARTBEAT" and m.get_srcComponent() == 1:
            self.mode = int(m.custom_mode)
            self.armed = bool(m.base_mode & 128)
        elif t == "STATUSTEXT" and str(m.text).startswith("KSG:"):
            self.texts.append(str(m.text))
        elif t == "NAMED_VALUE_FLOAT" and m.name == "KSG_ALIVE":
            self.alive.append((int(m.time_boot_ms), float(m.value)))

    def pump(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            m = self.conn.recv_match(blocking=True, timeout=0.05)
            if m is not None:
                self._take(m)

    def until(self, predicate, wall_s: float) -> bool:
        end = time.monotonic() + wall_s
        while time.monotonic() < end:
            if predicate():
                return True
            self.pump(0.05)
        return predicate()

    def first_alive(self, value: float, after_ms: int = 0) -> int | None:
        return next((t for t, v in self.alive if v == value and t >= after_ms), None)

    def armed_at(self) -> int:
        """Vehicle time of the guard's first report of an armed trial (earlier reports may be an earlier guard's)."""
        assert self.until(lambda: self.first_alive(GuardState.ARMED) is not None, 30.0), self.texts
        return self.first_alive(GuardState.ARMED)

    def param(self, name: str) -> float:
        for _ in range(5):
            self.conn.mav.param_request_read_send(1, 1, name.encode(), -1)
            end = time.monotonic() + 1.0
            while time.monotonic() < end:
                m = self.conn.recv_match(blocking=True, timeout=0.1)
                if m is None:
                    continue
                self._take(m)
                if m.get_type() == "PARAM_VALUE" and m.param_id == name:
                    return float(m.param_value)
        raise AssertionError(f"no PARAM_VALUE for {name}")

    def set_mode(self, mode: int) -> None:
        self.conn.mav.command_long_send(1, 1, 176, 0, 1, mode, 0, 0, 0, 0, 0)

    def land(self, wall_s: float = 120.0) -> bool:
        """LAND (ArduCopter mode 9) until the vehicle disarms, so the next test starts from the ground whatever this
        one left flying (the guard's LOITER descends on a SITL's resting throttle, and a vehicle found landed but
        still armed in it takes no new takeoff). Whether it disarmed (never raises: called in clean-ups)."""
        self.pump(0.5)
        if self.armed is not False:
            self.set_mode(9)
        return self.until(lambda: self.armed is False, wall_s)

    def close(self) -> None:
        self.conn.close()


def start_tuner(device: str, profile: str, spec: dict) -> tuple[subprocess.Popen, dict]:
    """The tuner stand-in (``guard_trial_process.py``), flying a guarded trial; returns it (and its baseline and
    trial values) once the guard armed the trial."""
    env = dict(os.environ, MAVLINK20="1")
    proc = subprocess.Popen([sys.executable, str(HERE / "guard_trial_process.py"), device, profile,
                             json.dumps(spec)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
    lines = []
    for line in proc.stdout:
        lines.append(line)
        if line.startswith("ARMED"):
            return proc, json.loads(proc.stdout.readline())
    proc.wait(10)
    raise AssertionError("tuner stand-in ended before arming the guard:\n" + "".join(lines[-30:]))


def stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)


def assert_baseline(obs: Observer, baseline: dict[str, float]) -> None:
    for name, value in baseline.items():
        assert obs.param(name) == pytest.approx(value, rel=1e-6), name
