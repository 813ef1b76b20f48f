"""Helpers shared by the benchmark scripts: machine description and the results file each benchmark writes."""

from __future__ import annotations

from contextlib import contextmanager

import datetime as _dt
import os
import platform
import re
import subprocess
from pathlib import Path

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"


def machine() -> str:
    """One line: CPU model, cores, Python and numpy versions, date (UTC)."""
    cpu = platform.processor() or "unknown CPU"
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, timeout=10).stdout
        m = re.search(r"Model name:\s*(.+)", out)
        cpu = m.group(1).strip() if m else cpu
    except (OSError, subprocess.SubprocessError):
        pass
    import numpy

    date = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return (f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, numpy {numpy.__version__}, "
            f"{date}")


def write_result(name: str, body: str) -> Path:
    """Write ``body``, a benchmark's full output in Markdown (machine, date, command, tables), to
    ``benchmarks/NAME/results.md``; ``scripts/benchmarks_page.py`` takes the headline for BENCHMARKS.md from it."""
    path = BENCH / name / "results.md"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(body.strip() + "\n")
    print(f"wrote {path}; `python scripts/benchmarks_page.py` puts its headline into BENCHMARKS.md")
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


def refly_in_turn(d, ep, gains: dict[str, dict[str, float]], n: int = 3) -> dict[str, list[float]]:
    """On the vehicle the campaign in ``d`` left hovering (reached at Endpoint ``ep``): the baseline, then each of
    ``gains`` ({label: {parameter: value}}), flown in turn ``n`` times (the same condition on average) through the
    tuner's own objective; lands. Returns {"baseline" and each label: lap-2 RMS of each flight}."""
    from ksbo_mav.mav.objective import MavlinkObjective
    from ksbo_mav.mav.params import load_snapshot
    from ksbo_mav.mav.vehicle import Vehicle

    snap = load_snapshot(d)
    v = Vehicle.connect(ep, snap.profile)
    try:
        v.setup_streams()
        base = snap.baseline()
        obj = MavlinkObjective(v, base, Path(d) / "refly", first_index=0)
        xs = {"baseline": v.gain_map.from_params(base), **{k: v.gain_map.from_params(g) for k, g in gains.items()}}
        out: dict[str, list[float]] = {k: [] for k in xs}
        for _ in range(n):
            for k, x in xs.items():
                out[k].append(_fly_retrying(obj, x, k))
        v.land()
        return out
    finally:
        v.close()


def _fly_retrying(obj, x, label: str, tries: int = 3) -> float:
    """Lap-2 RMS of one flight of ``x``; a flight the tuner stopped for its own sake (it fell behind the vehicle on
    a loaded machine, the link) is flown again, up to ``tries`` times, and said on stderr."""
    import sys

    from ksbo_mav.errors import TrialStopped

    for k in range(tries):
        try:
            return obj.fly(x, label=label).score["rms_lap2_m"]
        except TrialStopped as e:
            print(f"re-flight of {label} stopped ({e}); flying it again", file=sys.stderr)
            if k == tries - 1:
                raise
    raise AssertionError("unreachable")
