"""Shared pieces of the real-autopilot tests: run the tuner as its own process against a SITL, read a vehicle's
full parameter set over a fresh connection, and compare it with a campaign's snapshot."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.params import load_snapshot
from ksbo_mav.mav.vehicle import Vehicle


def tool(*args: str, timeout: float = 400) -> subprocess.CompletedProcess:
    """``ksbo-mav ARGS`` in its own process. A campaign (``tune``) flies no validation flights unless the
    arguments ask for them (``--validation``): the tests that test them say so, the others stay short."""
    if args[:1] == ("tune",) and "--dry-run" not in args and "--validation" not in args:
        args = (*args, "--validation", "off")
    env = dict(os.environ, MAVLINK20="1")
    return subprocess.run([sys.executable, "-m", "ksbo_mav.cli", *args], capture_output=True, text=True,
                          timeout=timeout, env=env)


def bench_pilot(sitl):
    """The bench pilot (``ksbo-mav sim-pilot``, :mod:`ksbo_sim.bench_pilot`) in its own process, watching an
    ArduCopter SITL on its third TCP port (the tuner and an observer keep the other two) and feeding its RC input;
    the caller stops it (``.stop()`` returns what it printed)."""
    from ksbo_sim.bench_pilot import PilotProcess

    return PilotProcess(f"tcp:127.0.0.1:{sitl.tcp_ports[2]}")


def endpoint(sitl, port: int | None = None) -> Endpoint:
    if sitl.kind == "ardupilot":
        return Endpoint("tcp", "127.0.0.1", port or sitl.tcp_ports[1])
    return Endpoint("udp", "127.0.0.1", port or sitl.udp_port)


def read_all(sitl, profile: str) -> tuple[dict[str, float], bool]:
    """Every parameter of the vehicle (fresh download on a second connection) and whether it is armed.

    By the PARAM protocol: ArduPilot's MAVLink FTP answers on another port only while the client of the port that
    used it first is still connected (its FTP thread waits on that port's send buffer), so a second port's FTP
    request after a campaign on the first waits ~11 s for nothing before the tool falls back to it anyway."""
    v = Vehicle.connect(endpoint(sitl), profile, sysid=250, compid=190, param_ftp=False)
    try:
        hb = v.link.wait_heartbeat(5.0)
        return {n: p.value for n, p in v.params.table.items()}, bool(hb.base_mode & 128)
    finally:
        v.close()


def param_diff(campaign: Path, now: dict[str, float]) -> dict[str, tuple[float, float]]:
    """Parameters whose value differs from the campaign's snapshot, except those the autopilot writes itself:
    {name: (snapshot, now)} (ksbo_mav.mav.params.Snapshot.off)."""
    return load_snapshot(campaign).off(now)


def trials(campaign: Path) -> list[dict]:
    return [json.loads(p.read_text()) for p in sorted((campaign / "trials").glob("trial_*.json"))]


#: Outcomes of a trial this computer spoiled, not the gains ("client": its setpoints went out late by the vehicle's
#: clock; "telemetry": the lap could not be measured): the campaign flies it again (TrialOutcome.retry).
SPOILED = ("client", "telemetry")


def counted_trials(campaign: Path) -> list[dict]:
    """The trials the campaign counted. A loaded machine may spoil one now and then: those are flown again and must
    be nothing but SPOILED ones, the same gains flown next."""
    recs = trials(campaign)
    for i, r in enumerate(recs):
        if r["outcome"] in SPOILED:
            assert i + 1 < len(recs) and recs[i + 1]["gains"] == r["gains"], (r["outcome"], r["message"])
    return [r for r in recs if r["outcome"] not in SPOILED]


def accept_then_restore(sitl, d: Path, summary: dict, profile: str, port_args: list[str]) -> None:
    """`ksbo-mav accept` leaves the best gains on the vehicle; `ksbo-mav restore` brings back the snapshot (every
    parameter, autopilot-updated ones aside)."""
    import pytest

    r = tool("accept", str(d), *port_args)
    assert r.returncode == 0, r.stderr
    now, _ = read_all(sitl, profile)
    for name, value in summary["best"]["values"].items():
        assert now[name] == pytest.approx(value, rel=1e-6)
    r = tool("restore", str(d), *port_args)
    assert r.returncode == 0, r.stderr
    now, _ = read_all(sitl, profile)
    assert not param_diff(d, now)


def short_campaign(sitl, d: Path) -> tuple[Path, dict, str]:
    """`ksbo-mav tune` from the ground: baseline + 1 optimiser trial + 1 confirmation; (dir, summary, stderr)."""
    r = tool("tune", str(d), *sitl.cli_args, "--prior", "none", "--budget", "2", "--json")
    assert r.returncode == 0, r.stderr[-3000:]
    return d, json.loads(r.stdout[r.stdout.index("{"):]), r.stderr


def tune_behind_link(sitl, d: Path, *args: str):
    """``ksbo-mav tune d ARGS`` behind the link emulator (on the SITL's first TCP port) and a second connection the
    tuner does not use (its second port): (emulator, observer, the tuner's process, its connection arguments)."""
    from guard_helpers import Observer

    from ksbo_sim.linkproc import LinkEmulator
    from ksbo_sim.process import free_udp_port

    gport = free_udp_port()
    emu = LinkEmulator(f"tcp:127.0.0.1:{sitl.tcp_port}", f"udp:127.0.0.1:{gport}")
    obs = Observer(f"tcp:127.0.0.1:{sitl.tcp_ports[1]}")
    conn = ["--udp", f"127.0.0.1:{gport}"]
    proc = subprocess.Popen([sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), *conn, *args],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    return emu, obs, proc, conn


def wait_for_trial(proc, d: Path, obs, k: int, wall_s: float) -> None:
    """Until trial ``k``'s tlog is open (the tuner still running), pumping the observer."""
    deadline = time.monotonic() + wall_s
    while not (d / "trials" / f"trial_{k:03d}.tlog").exists():
        assert proc.poll() is None and time.monotonic() < deadline, proc.stdout.read()[-3000:]
        obs.pump(0.1)
