"""Helpers shared by the benchmark scripts not yet sweeps: machine description, the results file each writes, our
simulator or a SITL to fly; the re-fly in turn and the parameters left changed are ksbo_bench's (re-exported)."""

from __future__ import annotations

from contextlib import contextmanager

import datetime as _dt
from pathlib import Path

from ksbo_bench.record import machine as _machine
from ksbo_bench.kinds.independent_refly import changed_params, refly_in_turn  # noqa: E402,F401 - re-exported
from ksbo_bench.kinds.vehicles import SPEED  # noqa: E402,F401 - re-exported

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"


def machine() -> str:
    """One line: CPU model, cores, Python and numpy versions (ksbo_bench's), date (UTC)."""
    date = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return f"{_machine()}, {date}"


def write_result(name: str, body: str) -> Path:
    """Write ``body``, a benchmark's full output in Markdown (machine, date, command, tables), to
    ``benchmarks/NAME/results.md``; ``ksbo-bench report`` takes the headline for BENCHMARKS.md from it."""
    path = BENCH / name / "results.md"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(body.strip() + "\n")
    print(f"wrote {path}; `ksbo-bench report` puts its headline into BENCHMARKS.md")
    return path


def append_record(path: Path, rec: dict) -> None:
    """Print ``rec`` as one JSON line and append it to the runs file ``path`` (created with its folder)."""
    import json

    print(json.dumps(rec), flush=True)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a") as fh:
        fh.write(json.dumps(rec) + "\n")


@contextmanager
def sim_and_endpoint(*extra: str):
    """Our simulator in its own process (lockstep) sending to a free UDP port; yields (process, the Endpoint a
    tuner listens on)."""
    from ksbo_mav.mav.link import Endpoint
    from ksbo_sim.process import SimProcess, free_udp_port

    port = free_udp_port()
    with SimProcess("--lockstep", *extra, out_port=port) as sim:
        yield sim, Endpoint("udp", "127.0.0.1", port)


def endpoint(sitl, second: bool = False):
    """(tune's connection arguments, the Endpoint) of a SITL: ArduCopter's first (or second) TCP port, PX4's UDP."""
    from ksbo_mav.mav.link import Endpoint

    if sitl.kind == "ardupilot":
        port = sitl.tcp_ports[1] if second else sitl.tcp_port
        return ["--tcp", f"127.0.0.1:{port}"], Endpoint("tcp", "127.0.0.1", port)
    return ["--udp", f"127.0.0.1:{sitl.udp_port}"], Endpoint("udp", "127.0.0.1", sitl.udp_port)


@contextmanager
def campaign_vehicle(sitl, d: Path, out: str):
    """The vehicle the campaign in ``d`` left hovering: the tuner's own objective (flights written to ``d / out``,
    restoring the snapshot's baseline) and the baseline gain vector x0 (d,). Lands when the block ends normally."""
    from ksbo_mav.mav.objective import MavlinkObjective
    from ksbo_mav.mav.params import load_snapshot
    from ksbo_mav.mav.vehicle import Vehicle

    _, ep = endpoint(sitl)
    snap = load_snapshot(d)
    v = Vehicle.connect(ep, snap.profile)
    try:
        v.setup_streams()
        base = snap.baseline()
        yield MavlinkObjective(v, base, d / out, first_index=0), v.gain_map.from_params(base)
        v.land()
    finally:
        v.close()
