"""A slow link (a radio's queue, a long Wi-Fi path): the link check measures the round trip and the command
service sizes its acknowledgement waits to it, so a command whose answer takes two seconds still gets through.
Our simulator in real time behind the link emulator, over loopback UDP."""

from __future__ import annotations

import os

os.environ["MAVLINK20"] = "1"

import pytest  # noqa: E402

from ksbo_mav.campaign.link_check import check_link  # noqa: E402
from ksbo_mav.errors import VehicleError  # noqa: E402
from ksbo_mav.mav.link import Endpoint  # noqa: E402
from ksbo_mav.mav.vehicle import Vehicle  # noqa: E402
from ksbo_sim.linkproc import LinkEmulator  # noqa: E402
from ksbo_sim.process import SimProcess, free_udp_port  # noqa: E402

CMD_INTERVAL = 511  # SET_MESSAGE_INTERVAL: our simulator acknowledges it
HEARTBEAT_ID = 0


@pytest.mark.network
@pytest.mark.timeout(180)
def test_command_waits_follow_the_measured_round_trip() -> None:
    gport, vport = free_udp_port(), free_udp_port()
    emu = LinkEmulator(f"udpin:127.0.0.1:{vport}", f"udp:127.0.0.1:{gport}",
                       "down=20000,up=20000,queue=16384,latency=0.8")
    sim = SimProcess(out_port=vport)
    try:
        v = Vehicle.connect(Endpoint("udp", "127.0.0.1", gport), "sim-planar")
        try:
            # One attempt of the default second cannot hear an answer that needs 1.6 s.
            with pytest.raises(VehicleError, match="after 1 attempts of 1.0 s each"):
                v.cmd.command(CMD_INTERVAL, HEARTBEAT_ID, 1_000_000, retries=1)
            said: list[str] = []
            fig = check_link(v, said.append, seconds=2.0)
            assert fig.rtt_ms is not None and fig.rtt_ms > 1500
            assert any(s.startswith("commands: waiting up to") for s in said), said
            v.link.pump(3.0)  # the late answer to the refused attempt arrives and is dropped here
            assert v.cmd.command(CMD_INTERVAL, HEARTBEAT_ID, 1_000_000, retries=1) == 0
        finally:
            v.close()
    finally:
        sim.stop()
        emu.stop()
