"""A fresh vehicle for one cell, on the node the cell landed on: an autopilot SITL on a claimed instance number
(ksbo_sim.sitl_instances: its ports are this cell's alone on this machine) or our simulator as its own process in
lockstep (the JSBSim copter, or the planar vehicle of the paper's task). Conditions are set before the campaign
starts; a change at trial N is set by a watcher while the campaign flies; a link emulator may stand between the
vehicle and the tuner.

Key values read here: ``vehicle`` ("ardupilot", "px4", "copter3d" or "planar"), ``build`` (another SITL build
beside the default, a folder of shared/sitl such as "px4-main", or a ``run`` script's path), ``speedup`` (SITL;
default ArduCopter 10, PX4 5), ``sitl_params`` (a table set at start: ``SIM_WIND_SPD``, noise, battery ...),
``personality`` and ``sim_args`` (our simulator: "ardupilot" or "px4"; ``ksbo-mav sim`` arguments such as
["--drag", "1.5"] or ["--wind-step", "40:1.0"]), ``link`` (a SITL through our link emulator, ``python -m
ksbo_sim.linkemu``, with this shape, e.g. "down=4000,up=2000,queue=1024,loss=0.05"; PX4 through its MAVLink
instance rated for a radio).
"""

from __future__ import annotations

import os
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator

from ksbo_bench.cell_errors import InfraError

SITL_KINDS = ("ardupilot", "px4")
SPEED = {"ardupilot": 10.0, "px4": 5.0}
OURS = ("copter3d", "planar")
VEHICLES = (*SITL_KINDS, *OURS)


def is_sitl(key: dict[str, Any]) -> bool:
    return key.get("vehicle") in SITL_KINDS


@dataclass
class Fresh:
    """A vehicle ready for a campaign: ``conn`` (what `tune` gets to reach it), ``ep`` (the Endpoint a client
    connects to), ``sitl`` (the Sitl, or None for our simulator), ``direct`` (an Endpoint that bypasses a link
    emulator: where the parameters left changed are read), ``info`` (what the setup says: the emulator's counters
    once it stopped)."""

    conn: list[str]
    ep: Any
    sitl: Any = None
    direct: Any = None
    info: dict[str, Any] = field(default_factory=dict)


def _build_env(key: dict[str, Any]) -> None:
    """Point ksbo_sim.sitl at the declared build (``build``) for this process."""
    from ksbo_sim.sitl import ENV, find_run_script

    build = key.get("build")
    if not build:
        return
    p = Path(build)
    if not p.is_absolute():
        p = find_run_script(key["vehicle"]).parents[1] / build / "run"  # beside the default build
    if not p.is_file():
        raise InfraError(f"SITL build {build!r} not found on this node ({p})")
    os.environ[ENV[key["vehicle"]]] = str(p)


@contextmanager
def _ours(key: dict[str, Any]) -> Iterator[Fresh]:
    from ksbo_mav.mav.link import Endpoint
    from ksbo_sim.process import SimProcess, SimStartError, free_udp_port

    port = free_udp_port()
    args = [*map(str, key.get("sim_args", []))]
    if key["vehicle"] == "copter3d":
        args = ["--vehicle", "copter3d", "--personality", key.get("personality", "ardupilot"), *args]
    try:
        sim = SimProcess("--lockstep", *args, out_port=port)
    except (SimStartError, OSError) as e:
        raise InfraError(str(e)) from e
    conn = ["--udp", f"127.0.0.1:{port}"] + (["--profile", "sim-planar"] if key["vehicle"] == "planar" else [])
    ep = Endpoint("udp", "127.0.0.1", port)
    with sim:
        yield Fresh(conn, ep, None, ep)


@contextmanager
def _linked(kind: str, sitl, shape: str, info: dict[str, Any]) -> Iterator[tuple[list[str], Any]]:
    """The tuner's side of our link emulator between the SITL and it (stopped, its counters in ``info``)."""
    from ksbo_mav.mav.link import Endpoint
    from ksbo_sim.linkproc import LinkEmulator
    from ksbo_sim.process import SimStartError, free_udp_port

    gport = free_udp_port()
    # PX4's API link runs at 4 MB/s and would flood any radio; its instance rated 4000 B/s stands for a radio port
    vehicle = f"tcp:127.0.0.1:{sitl.tcp_port}" if kind == "ardupilot" else f"udpin:127.0.0.1:{sitl.radio_udp_port}"
    try:
        emu = LinkEmulator(vehicle, f"udp:127.0.0.1:{gport}", shape)
    except (SimStartError, OSError) as e:
        raise InfraError(str(e)) from e
    try:
        yield ["--udp", f"127.0.0.1:{gport}"], Endpoint("udp", "127.0.0.1", gport)
    finally:
        info["link"] = emu.stop()


@contextmanager
def fresh_vehicle(key: dict[str, Any], workdir: Path) -> Iterator[Fresh]:
    """A fresh vehicle for ``key``, stopped at the end."""
    from ksbo_mav.mav.link import Endpoint

    kind = key["vehicle"]
    if kind in OURS:
        with _ours(key) as fresh:
            yield fresh
        return
    from ksbo_sim import sitl_instances
    from ksbo_sim.sitl import SitlNotFound

    _build_env(key)
    try:
        sitl = sitl_instances.start_claimed(kind, key.get("speedup", SPEED[kind]), workdir=workdir / "sitl")
    except SitlNotFound:
        raise  # not an infrastructure hiccup: this node has no such SITL; said, not retried
    except (RuntimeError, OSError, TimeoutError) as e:
        raise InfraError(f"{kind} SITL did not boot: {str(e)[:300]}") from e
    try:
        if kind == "px4":
            sitl.set_param("COM_RCL_EXCEPT", 4, int32=True)  # no RC in SITL: allow OFFBOARD without it
        for name, value in key.get("sitl_params", {}).items():
            sitl.set_param(name, value)
        direct = (Endpoint("tcp", "127.0.0.1", sitl.tcp_port) if kind == "ardupilot"
                  else Endpoint("udp", "127.0.0.1", sitl.udp_port))
        if key.get("link"):
            info: dict[str, Any] = {}
            with _linked(kind, sitl, key["link"], info) as (conn, ep):
                fresh = Fresh(conn, ep, sitl, direct, info)
                yield fresh
            return
        conn = (["--tcp", f"127.0.0.1:{sitl.tcp_port}"] if kind == "ardupilot"
                else ["--udp", f"127.0.0.1:{sitl.udp_port}"])
        yield Fresh(conn, direct, sitl, direct)
    finally:
        sitl.stop()


@contextmanager
def change_at(key: dict[str, Any], journal: Path, sitl, log: dict) -> Iterator[None]:
    """While the campaign flies: ``change_at`` (a trial number) and ``change_params`` (a table): set those SITL
    parameters once that many trials are journalled (ArduCopter: through its second TCP port, the campaign holds
    the first); ``centre_sticks_at`` (a trial number): ArduCopter SITL's transmitter sticks 1-4 centred then (its
    throttle rests at 1000 us, and the validation's LOITER hold refuses that, as a pilot's centred transmitter)."""
    todo = []
    if key.get("change_at") and key.get("change_params"):
        todo.append((int(key["change_at"]), "change"))
    if key.get("centre_sticks_at") is not None and key.get("vehicle") == "ardupilot":
        todo.append((int(key["centre_sticks_at"]), "sticks"))
    if not todo or sitl is None:
        yield
        return
    done = threading.Event()

    def act(what: str) -> None:
        if what == "sticks":
            from ksbo_bench.kinds.flight_ways import centre_sticks

            centre_sticks(sitl.instance)
            log["sticks_centred_at_entries"] = len(journal.read_text().splitlines()) if journal.exists() else 0
            return
        log["changed"] = {n: sitl.set_param(n, v, second_port=True) for n, v in key["change_params"].items()}
        log["changed_at_entries"] = len(journal.read_text().splitlines())

    def watch() -> None:
        left = sorted(todo)
        while left and not done.is_set():
            n = len(journal.read_text().splitlines()) if journal.exists() else 0
            while left and n >= left[0][0]:
                act(left.pop(0)[1])
            time.sleep(0.2)

    t = threading.Thread(target=watch, daemon=True)
    t.start()
    try:
        yield
    finally:
        done.set()
        t.join(5)
