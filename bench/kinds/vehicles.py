"""A fresh vehicle for one campaign cell, on the node the cell landed on: an autopilot SITL on a claimed instance
number (ksbo_sim.sitl_instances: its ports are this cell's alone on this machine) or our JSBSim copter as its own
process in lockstep. Conditions are set before the campaign starts; a change at trial N is set by a watcher while
the campaign flies.

Key values read here: ``vehicle`` ("ardupilot", "px4" or "copter3d"), ``build`` (another SITL build beside the
default, a folder of shared/sitl such as "px4-main", or a ``run`` script's path), ``speedup`` (SITL; default
ArduCopter 10, PX4 5), ``sitl_params`` (a table set at start: ``SIM_WIND_SPD``, noise, battery ...),
``personality`` and ``sim_args`` (our copter: "ardupilot" or "px4"; ``ksbo-mav sim`` arguments such as
["--drag", "1.5"] or ["--set", "MOT_THST_HOVER=0.5"]).
"""

from __future__ import annotations

import os
import threading
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Iterator

from ksbo_bench.cell_errors import InfraError

SITL_KINDS = ("ardupilot", "px4")
SPEED = {"ardupilot": 10.0, "px4": 5.0}
VEHICLES = (*SITL_KINDS, "copter3d")


def is_sitl(key: dict[str, Any]) -> bool:
    return key.get("vehicle") in SITL_KINDS


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
def fresh_vehicle(key: dict[str, Any], workdir: Path) -> Iterator[tuple[list[str], Any, Any]]:
    """(tune's connection arguments, the Endpoint a client connects to, the Sitl or None); stopped at the end."""
    from ksbo_mav.mav.link import Endpoint

    kind = key["vehicle"]
    if kind == "copter3d":
        from ksbo_sim.process import SimProcess, SimStartError, free_udp_port

        port = free_udp_port()
        args = ["--vehicle", "copter3d", "--personality", key.get("personality", "ardupilot"),
                *map(str, key.get("sim_args", []))]
        try:
            sim = SimProcess("--lockstep", *args, out_port=port)
        except (SimStartError, OSError) as e:
            raise InfraError(str(e)) from e
        with sim:
            yield ["--udp", f"127.0.0.1:{port}"], Endpoint("udp", "127.0.0.1", port), None
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
        if kind == "ardupilot":
            yield ["--tcp", f"127.0.0.1:{sitl.tcp_port}"], Endpoint("tcp", "127.0.0.1", sitl.tcp_port), sitl
        else:
            yield ["--udp", f"127.0.0.1:{sitl.udp_port}"], Endpoint("udp", "127.0.0.1", sitl.udp_port), sitl
    finally:
        sitl.stop()


@contextmanager
def change_at(key: dict[str, Any], journal: Path, sitl, log: dict) -> Iterator[None]:
    """``change_at`` (a trial number) and ``change_params`` (a table): set those SITL parameters once that many
    trials are journalled (ArduCopter: through its second TCP port, the campaign holds the first)."""
    at, params = key.get("change_at"), key.get("change_params", {})
    if not at or not params or sitl is None:
        yield
        return
    done = threading.Event()

    def watch() -> None:
        while not done.is_set():
            if journal.exists() and len(journal.read_text().splitlines()) >= at:
                log["changed"] = {n: sitl.set_param(n, v, second_port=True) for n, v in params.items()}
                log["changed_at_entries"] = len(journal.read_text().splitlines())
                return
            time.sleep(0.2)

    t = threading.Thread(target=watch, daemon=True)
    t.start()
    try:
        yield
    finally:
        done.set()
        t.join(5)
