"""Our simulator in real time behind the link emulator, for the link tests (loopback UDP)."""

from __future__ import annotations

from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.linkcheck import LinkFigures
from ksbo_mav.mav.vehicle import Vehicle
from ksbo_sim.linkproc import LinkEmulator
from ksbo_sim.process import SimProcess, free_udp_port


def realtime_through(shape: str) -> tuple[SimProcess, LinkEmulator, Endpoint]:
    """The simulator in real time (its clock runs on the ground, as a vehicle's does) behind the emulator shaped
    ``shape``: (simulator, emulator, the endpoint a tuner listens on). The caller stops both."""
    gport, vport = free_udp_port(), free_udp_port()
    emu = LinkEmulator(f"udpin:127.0.0.1:{vport}", f"udp:127.0.0.1:{gport}", shape)
    sim = SimProcess(out_port=vport)
    return sim, emu, Endpoint("udp", "127.0.0.1", gport)


def check_link_through(shape: str, seconds: float = 2.0) -> tuple[LinkFigures, int, list[str]]:
    """The campaign's link check through a link shaped ``shape``: (its figures, the mission rate it left, what it
    said)."""
    from ksbo_mav.campaign.mission_rate import check_link

    sim, emu, ep = realtime_through(shape)
    said: list[str] = []
    try:
        v = Vehicle.connect(ep, "sim-planar")
        try:
            fig = check_link(v, said.append, seconds=seconds)
            return fig, v.mission.rate_hz, said
        finally:
            v.close()
    finally:
        sim.stop()
        emu.stop()
