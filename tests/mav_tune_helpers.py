"""Shared pieces of the MAVLink tuning-client tests: the simulator in its own process (lockstep, sending to a
UDP port where the client listens, as a ground station; launcher in :mod:`ksbo_sim.process`), and an
independent second connection of the tuner's own client for fresh reads."""

from __future__ import annotations

import os

os.environ["MAVLINK20"] = "1"

from contextlib import contextmanager  # noqa: E402
from pathlib import Path  # noqa: E402

from ksbo_mav.mav.link import Endpoint  # noqa: E402
from ksbo_mav.mav.vehicle import Vehicle  # noqa: E402
from ksbo_sim.process import SimProcess, free_udp_port  # noqa: E402

GAINS = ("POS_X_P", "POS_X_I", "POS_X_D", "POS_Z_P", "POS_Z_I", "POS_Z_D", "ATT_PIT_P", "ATT_PIT_I", "ATT_PIT_D")


@contextmanager
def sim_and_endpoint(*extra: str):
    """Yield (sim process, endpoint the tuner listens on)."""
    port = free_udp_port()
    sim = SimProcess("--lockstep", *extra, out_port=port)
    try:
        yield sim, Endpoint("udp", "127.0.0.1", port)
    finally:
        sim.stop()


def fresh_read(sim: SimProcess, names=GAINS, profile: str | None = "sim-planar") -> dict[str, float]:
    """Read parameters over a second, independent connection (talks first to the simulator's own port)."""
    v = Vehicle.connect(Endpoint("udpout", "127.0.0.1", sim.port), profile, sysid=250, compid=190)
    try:
        return {n: v.params.read(n, retries=8) for n in names}
    finally:
        v.close()


def baseline() -> dict[str, float]:
    from ksbo_mav.profiles import load_profile

    import numpy as np

    prof = load_profile("sim-planar")
    return {n: float(np.float32(x)) for n, x in zip(prof.names, prof.default)}


def short_figure8(profile: Path) -> Path:
    """Rewrite the 3-D copter profile file ``profile`` with a short figure-8 (4 m x 1 m, 8 s period, 2 s lead-in):
    a trial takes a third of the profile's. Returns ``profile``."""
    import re

    text = profile.read_text()
    for key, value in (("scale_m", 4.0), ("scale_east_m", 1.0), ("period_s", 8.0), ("lead_in_s", 2.0)):
        text = re.sub(rf"\n{key} = \S+", f"\n{key} = {value}", text, count=1)
    profile.write_text(text)
    return profile
