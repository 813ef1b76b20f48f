"""The onboard guard on a real ArduCopter SITL with Lua scripting: it restores the baseline gains and stops the
vehicle itself when the tuner's link dies mid-trial, when the box is left, and (gains only) when a pilot takes
over; and it goes away without a trace.

The tuner is a process of its own (``guard_trial_process.py``) holding SERIAL0; the test watches the vehicle on a
second MAVLink connection (SERIAL1, 5762+10N) that the tuner does not use, and measures on the vehicle's clock:
the cut is the last vehicle timestamp seen before the tuner was killed, the restore is the timestamp of the
guard's ``KSG_ALIVE`` = tripped, sent in the same script tick that wrote the gains back.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import sitl_or_skip
from sitl_instances import release_stopped

from ksbo_mav.mav.guard_script import (
    GUARD_PARAMS,
    SCRIPT_NAME,
    GuardState,
    config_for,
    new_config_id,
)
from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.monitor import limits_from_profile
from ksbo_mav.mav.onboard_guard import OnboardGuard
from ksbo_mav.mav.vehicle import Vehicle

pytestmark = [pytest.mark.sitl, pytest.mark.network, pytest.mark.timeout(600)]

#: Slow enough that the tuner stand-in's heartbeats (every 1/6 of the link timeout, in vehicle time) keep up on a
#: busy 2-core machine; the guard counts on the vehicle's clock, so the speed-up changes no vehicle-time figure.
SPEEDUP = 3
BRAKE, LOITER, GUIDED = 17, 5, 4
HERE = Path(__file__).resolve().parent


@pytest.fixture(scope="module")
def scripting_sitl(tmp_path_factory):
    """ArduCopter SITL with SCR_ENABLE 1: set, then the SITL restarted on its saved parameters (the setting takes
    effect at boot, as on a flight controller)."""
    wd = tmp_path_factory.mktemp("guard-sitl")
    sitl = sitl_or_skip("ardupilot", SPEEDUP, workdir=wd)
    for _ in range(4):
        if sitl.set_param("SCR_ENABLE", 1) == 1 and (wd / "scripts").is_dir():
            break  # booted with scripting on: it made its scripts directory
        time.sleep(2.0)  # the SITL writes its parameter storage to eeprom.bin a moment after the change
        sitl.stop()
        release_stopped()
        sitl = sitl_or_skip("ardupilot", SPEEDUP, workdir=wd, keep_params=True)
    else:
        sitl.stop()
        pytest.fail("ArduCopter SITL did not boot with SCR_ENABLE 1")
    yield sitl
    sitl.stop()
    release_stopped()


class Observer:
    """A second connection (SERIAL1) that reads what the vehicle does: its clock, mode, parameters, the guard's
    messages. Its system id (250) is not the one the guard watches."""

    def __init__(self, sitl) -> None:
        from pymavlink import mavutil

        self.conn = mavutil.mavlink_connection(f"tcp:127.0.0.1:{sitl.tcp_ports[1]}", source_system=250,
                                               source_component=190, autoreconnect=False)
        assert self.conn.wait_heartbeat(timeout=10) is not None
        self.conn.mav.command_long_send(1, 1, 511, 0, 2, 50_000, 0, 0, 0, 0, 0)  # SYSTEM_TIME at 20 Hz, this link
        self.vehicle_ms = 0
        self.mode = -1
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

    def close(self) -> None:
        self.conn.close()


def start_tuner(sitl, spec: dict) -> tuple[subprocess.Popen, dict]:
    """The tuner stand-in, flying a guarded trial; returns it (and its baseline/trial values) once ARMED."""
    env = dict(os.environ, MAVLINK20="1")
    proc = subprocess.Popen([sys.executable, str(HERE / "guard_trial_process.py"), str(sitl.tcp_port),
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


TRIAL = {"PSC_POSXY_P": 1.8, "PSC_VELXY_P": 3.2}


def test_link_cut_restores_baseline_and_stops_on_board(scripting_sitl):
    obs = Observer(scripting_sitl)
    proc, values = start_tuner(scripting_sitl, {"trial": TRIAL})
    try:
        obs.pump(1.0)
        assert obs.param("PSC_POSXY_P") == pytest.approx(1.8)  # the trial gains are flying
        cut_ms = obs.vehicle_ms  # the last vehicle time seen while the tuner still held the link
        stop(proc)
        assert obs.until(lambda: obs.first_alive(GuardState.TRIPPED, cut_ms) is not None, 60.0), obs.texts
        restored_ms = obs.first_alive(GuardState.TRIPPED, cut_ms)
        assert_baseline(obs, values["baseline"])
        assert obs.until(lambda: obs.mode in (BRAKE, LOITER), 5.0), obs.texts  # the next heartbeat shows it
        assert obs.param("KSG_TRIP") == 1
        assert any("link lost" in t for t in obs.texts), obs.texts
        timeout_ms = 3000  # the profile's heartbeat_timeout_s
        print(f"link cut at vehicle {cut_ms} ms, baseline back and BRAKE at {restored_ms} ms: "
              f"{restored_ms - cut_ms} ms (limit {timeout_ms + 1000} ms); guard said {obs.texts}")
        assert restored_ms - cut_ms <= timeout_ms + 1000
        assert obs.until(lambda: obs.mode == LOITER, 30.0)  # BRAKE, then the safe mode
    finally:
        stop(proc)
        obs.close()


def test_box_left_restores_baseline_and_brakes(scripting_sitl):
    obs = Observer(scripting_sitl)
    # The figure-8 starts at the origin's north 0: a 3 m box, and the trial flown 6 m north.
    proc, values = start_tuner(scripting_sitl, {"trial": TRIAL, "limits": {"x_max_m": 3.0},
                                                "fly_to": [6.0, 0.0, -10.0]})
    try:
        armed_ms = obs.armed_at()
        assert obs.until(lambda: obs.first_alive(GuardState.TRIPPED, armed_ms) is not None, 60.0), obs.texts
        assert obs.param("KSG_TRIP") == 2
        assert_baseline(obs, values["baseline"])
        assert obs.until(lambda: obs.mode in (BRAKE, LOITER), 5.0)
        assert any("north" in t for t in obs.texts), obs.texts
    finally:
        stop(proc)
        obs.close()


def test_pilot_mode_change_restores_baseline_and_keeps_the_pilots_mode(scripting_sitl):
    obs = Observer(scripting_sitl)
    proc, values = start_tuner(scripting_sitl, {"trial": TRIAL})
    try:
        armed_ms = obs.armed_at()
        obs.set_mode(LOITER)  # the pilot (a ground station on another link) takes over
        assert obs.until(lambda: obs.first_alive(GuardState.TRIPPED, armed_ms) is not None, 30.0), obs.texts
        assert obs.param("KSG_TRIP") == 4
        assert_baseline(obs, values["baseline"])
        obs.pump(3.0)  # the guard leaves the pilot's mode alone (no BRAKE)
        assert obs.mode == LOITER
    finally:
        stop(proc)
        obs.close()


def test_install_then_removal_leaves_no_script_and_default_parameters(scripting_sitl):
    v = Vehicle.connect(Endpoint("tcp", "127.0.0.1", scripting_sitl.tcp_port), "ardupilot-copter")
    try:
        gcs_sysid = v.params.read("MAV_GCS_SYSID")
        baseline = {name: v.params.read(name) for name in v.gain_map.param_names}
        guard = OnboardGuard(v.link, v.params, v.cmd)
        guard.install(config_for(limits_from_profile(v.profile), 3.0, baseline, new_config_id()))
        assert guard.answering() and v.params.read("MAV_GCS_SYSID") == v.link.mav.srcSystem
        guard.remove()
        for name, default in GUARD_PARAMS.items():
            assert v.params.read(name) == default
        assert v.params.read("MAV_GCS_SYSID") == gcs_sysid
        v.link.pump(1.0)
        guard.alive_wall = 0.0
        v.link.pump(3.0)
        assert guard.alive_wall == 0.0  # no KSG_ALIVE since the scripts restarted without it
    finally:
        v.close()
    assert not (scripting_sitl.workdir / "scripts" / SCRIPT_NAME).exists()
