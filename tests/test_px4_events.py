"""PX4's EVENT messages (id 410, unknown to pymavlink's dialect here) read by the tool: a frame as PX4 main sends it
(payload cut after its last non-zero byte, MAVLink 2 framing with the message's CRC seed) arrives on a real
loopback UDP link, and the Commander keeps its text apart from the STATUSTEXTs; another system's event and
another message are not taken for the vehicle's."""

from __future__ import annotations

import socket
import struct
import time

import pytest
from pymavlink.generator.mavcrc import x25crc

from ksbo_mav.mav import px4_events
from ksbo_mav.mav.commands import Commander
from ksbo_mav.mav.link import Endpoint, Link
from ksbo_mav.mav.wire import mavlink
from ksbo_sim.process import free_udp_port

pytestmark = pytest.mark.network

CRC_EXTRA = 160  # EVENT's CRC seed in common.xml


def event_frame(sub_id: int, severity: int, sysid: int = 1, compid: int = 1, seq: int = 0) -> bytes:
    payload = struct.pack("<IIHBBB", (1 << 24) | sub_id, 12345, seq, 0, 0, severity) + bytes(40)
    payload = payload.rstrip(b"\0")
    head = bytes([0xFD, len(payload), 0, 0, seq & 0xFF, sysid, compid]) + struct.pack("<I", px4_events.MSG_ID)[:3]
    crc = x25crc(head[1:] + payload)
    crc.accumulate(bytes([CRC_EXTRA]))
    return head + payload + struct.pack("<H", crc.crc)


def test_px4_events_on_a_real_link_are_kept_with_their_text():
    port = free_udp_port()
    link = Link(Endpoint("udp", "127.0.0.1", port))
    cmd = Commander(link)
    vehicle = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    hb = vehicle.heartbeat_encode(2, 12, 0, 0, 4).pack(vehicle)
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            for frame in (hb, event_frame(11464574, 3), event_frame(453929, 4, seq=1),
                          event_frame(5049764, 4, sysid=2, seq=2), event_frame(7777777, 6, seq=3)):
                s.sendto(frame, ("127.0.0.1", port))
            deadline = time.monotonic() + 5.0
            while len(cmd.events) < 3 and time.monotonic() < deadline:
                link.pump(0.1)
    finally:
        link.close()
    # another system's "Low battery" is not the vehicle's; an id the table does not know is said by number
    assert list(cmd.events) == [(3, "No offboard signal"), (4, "No manual control input"), (6, "PX4 event 7777777")]
    assert cmd.recent_events(2) == '"No manual control input", "PX4 event 7777777"' and cmd.received == 0
