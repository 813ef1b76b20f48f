"""Our simulator in real time behind the link emulator, and a plain ground station client, for the link tests
(loopback UDP)."""

from __future__ import annotations

import time
from collections import Counter

from pymavlink import mavutil

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


ALL_STREAMS = 0  # REQUEST_DATA_STREAM: every stream group


class GroundStation:
    """A second client on the router's other output: a heartbeat a second, its stream request (every group at
    ``hz``, as Mission Planner and MAVProxy send it), and a count of what it receives."""

    def __init__(self, device: str) -> None:
        self.conn = mavutil.mavlink_connection(device, source_system=250, source_component=190)
        self.got: Counter[str] = Counter()
        self._beat = 0.0

    def pump(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            if time.monotonic() - self._beat >= 1.0:
                self.conn.mav.heartbeat_send(6, 8, 0, 0, 0)
                self._beat = time.monotonic()
            m = self.conn.recv_match(blocking=True, timeout=0.05)
            if m is not None and m.get_srcSystem() == 1:
                self.got[m.get_type()] += 1

    def wait_for_the_router(self, timeout_s: float = 60.0) -> None:
        end = time.monotonic() + timeout_s
        while not self.got["HEARTBEAT"] and time.monotonic() < end:
            self.pump(0.2)
        assert self.got["HEARTBEAT"], "MAVProxy passed on no vehicle heartbeat"

    def ask_for_streams(self, hz: int) -> None:
        for _ in range(3):
            self.conn.mav.request_data_stream_send(1, 1, ALL_STREAMS, hz, 1)
            self.pump(0.2)
