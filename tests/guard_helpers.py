"""The onboard guard's tests, shared by the ArduCopter SITL and the built-in simulator: a second connection that
watches the vehicle (ksbo_sim.vehicle_watch), and the tuner stand-in (``guard_trial_process.py``) run as a process
of its own so that its link can be cut by killing it."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from ksbo_mav.mav.guard_script import GuardState
from ksbo_sim.vehicle_watch import VehicleWatch

HERE = Path(__file__).resolve().parent


class Observer(VehicleWatch):
    """A second connection (``device``, pymavlink's notation) that reads what the vehicle does
    (:class:`ksbo_sim.vehicle_watch.VehicleWatch`), with the guard's armed trial found."""

    def armed_at(self) -> int:
        """Vehicle time of the guard's first report of an armed trial (earlier reports may be an earlier guard's)."""
        assert self.until(lambda: self.first_alive(GuardState.ARMED) is not None, 30.0), self.texts
        return self.first_alive(GuardState.ARMED)


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
