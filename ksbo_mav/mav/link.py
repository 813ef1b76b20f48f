"""The connection to one vehicle: endpoint parsing, our own ids and heartbeat, a single-threaded message pump.

Everything that waits for the vehicle goes through :meth:`Link.pump` / :meth:`Link.wait`, so there are no
threads: a Ctrl-C lands in the main thread between two messages, and the tuner's safety code runs in order.
While pumping, the link sends our GCS heartbeat at 1 Hz (so the vehicle and other ground stations see us),
tracks the vehicle's heartbeat for link-loss detection, and hands every packet in both directions to the
optional :class:`~ksbo_mav.mav.tlog.TlogWriter` (pymavlink's own logging is empty on UDP, fact sheet 5.2).
"""

from __future__ import annotations

import contextlib
import io
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from ksbo_mav.errors import InputError, VehicleError
from ksbo_mav.mav.signing import SigningKey, start_signing
from ksbo_mav.mav.tlog import LINK_RECEIVED, LINK_SENT, TlogWriter
from ksbo_mav.mav.wire import mavlink, mavutil

#: Default ids: a companion-computer component on a GCS-range system id, so QGC/MAVProxy (255/190, 255/230)
#: can stay connected to the same vehicle without id clashes.
DEFAULT_SYSID = 245
DEFAULT_COMPID = mavlink.MAV_COMP_ID_ONBOARD_COMPUTER

MAV_TYPE_GCS = 6
#: Signed frames that fail our key's check, none passing, before a wait for the vehicle gives up: a vehicle sends
#: several a second, and a key that verifies none of them never will.
WRONG_KEY_FRAMES = 10
MAV_AUTOPILOT_INVALID = 8
#: While :meth:`Link.pump` works through a backlog, the idle hooks run after every this many messages (~0.5 ms).
IDLE_EVERY = 10

Handler = Callable[[Any], None]
Tap = Callable[[Any, bool], None]


@dataclass(frozen=True)
class Endpoint:
    """Where the vehicle is. ``kind``: ``udp`` (we listen, as a GCS), ``udpout`` (we talk first), ``tcp``,
    ``serial``; ``signing``: the key of a vehicle that signs its link (never shown: not in repr or str)."""

    kind: str
    host: str
    port: int = 0
    baud: int = 57600
    signing: SigningKey | None = field(default=None, repr=False, compare=False)

    @property
    def device(self) -> str:
        if self.kind == "udp":
            return f"udpin:{self.host}:{self.port}"
        if self.kind == "udpout":
            return f"udpout:{self.host}:{self.port}"
        if self.kind == "tcp":
            return f"tcp:{self.host}:{self.port}"
        return self.host

    def __str__(self) -> str:
        if self.kind == "serial":
            return f"serial {self.host} @ {self.baud}"
        return f"{self.kind} {self.host}:{self.port}"


def _host_port(text: str, what: str) -> tuple[str, int]:
    host, sep, port = text.rpartition(":")
    if not sep or not host:
        raise InputError(f"{what} needs HOST:PORT, got {text!r}")
    try:
        p = int(port)
    except ValueError:
        raise InputError(f"{what}: port {port!r} is not a number") from None
    if not 0 < p < 65536:
        raise InputError(f"{what}: port {p} outside 1..65535")
    return host, p


def parse_endpoint(udp: str | None = None, udpout: str | None = None, tcp: str | None = None,
                   serial: str | None = None) -> Endpoint:
    """Exactly one of the four connection options -> :class:`Endpoint` (clear error otherwise)."""
    given = [(k, v) for k, v in (("udp", udp), ("udpout", udpout), ("tcp", tcp), ("serial", serial)) if v]
    if len(given) != 1:
        raise InputError("give exactly one of --udp HOST:PORT, --udp-out HOST:PORT, --tcp HOST:PORT, "
                         "--serial DEV[:BAUD]")
    kind, text = given[0]
    if kind == "serial":
        dev, sep, baud = text.partition(":")
        try:
            return Endpoint("serial", dev, baud=int(baud) if sep else 57600)
        except ValueError:
            raise InputError(f"--serial: baud rate {baud!r} is not a number") from None
    host, port = _host_port(text, f"--{kind.replace('udpout', 'udp-out')}")
    return Endpoint(kind, host, port)


def _refuse_a_taken_port(endpoint: Endpoint) -> None:
    """VehicleError, one line naming the port and the fix, when another program already listens on the UDP port.

    pymavlink binds with SO_REUSEADDR, so beside a ground station that set it too (MAVProxy does) the bind would
    succeed and the kernel would hand each datagram to one of the two programs: both would lose messages without
    a word. A probe bound without SO_REUSEADDR fails whenever anyone holds the port, whatever they set."""
    import errno
    import socket

    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        probe.bind((endpoint.host, endpoint.port))
    except OSError as exc:
        if exc.errno != errno.EADDRINUSE:
            return  # a host that does not resolve or is not ours: pymavlink's own error below says so
        raise VehicleError(
            f"cannot listen on UDP {endpoint.host}:{endpoint.port}: another program (a ground station?) is already "
            f"listening on port {endpoint.port}; give ksbo-mav its own port, e.g. a second output of MAVProxy or "
            f"mavlink-router to 127.0.0.1:14551 and --udp 127.0.0.1:14551 (docs/flight-checklist.md, "
            f"\"Sharing the link with a ground station\")") from None
    finally:
        probe.close()


class Link:
    """A MAVLink 2 connection to one vehicle (the first non-GCS heartbeat we hear, or ``target_system``)."""

    def __init__(self, endpoint: Endpoint, sysid: int = DEFAULT_SYSID, compid: int = DEFAULT_COMPID,
                 target_system: int | None = None) -> None:
        if not (1 <= sysid <= 255 and 1 <= compid <= 255):
            raise InputError("--sysid and --compid must be in 1..255")
        self.endpoint = endpoint
        if endpoint.kind == "udp":
            _refuse_a_taken_port(endpoint)
        try:
            # pymavlink prints "[Errno 111] Connection refused sleeping" to stdout on every TCP retry; our one-line
            # error below says it all.
            with contextlib.redirect_stdout(io.StringIO()):
                self.conn = mavutil.mavlink_connection(endpoint.device, baud=endpoint.baud, source_system=sysid,
                                                       source_component=compid, autoreconnect=False)
        except (OSError, ValueError) as exc:
            raise VehicleError(f"cannot open {endpoint}: {exc}") from None
        # Our messages are MAVLink 2 even before the vehicle has spoken (ids > 255, e.g. ACTUATOR_OUTPUT_STATUS).
        self.conn.WIRE_PROTOCOL_VERSION = "2.0"
        self.conn.mav.WIRE_PROTOCOL_VERSION = "2.0"
        self.mav = self.conn.mav
        if endpoint.signing is not None:
            start_signing(self.conn, endpoint.signing, time.time())
        #: A frame with the signature flag arrived (the vehicle signs its link); a RADIO_STATUS arrived (a
        #: telemetry radio is on the link: ksbo_mav.mav.link_loss).
        self.signed_seen = False
        self.radio_heard = False
        self.target_system = target_system or 0
        self.target_component = 1
        self.tlog: TlogWriter | None = None
        self.handlers: list[Handler] = []
        #: Called on every turn of :meth:`pump` (e.g. to keep a setpoint stream alive while waiting for a reply).
        self.idle: list[Callable[[], None]] = []
        #: Called with (message as decoded from the wire, sent?) for every packet in both directions.
        self.taps: list[Tap] = []
        self._decoder = mavlink.MAVLink(None)
        self.last_heartbeat: Any = None
        self.last_heartbeat_wall = 0.0
        self._next_own_heartbeat = 0.0
        #: The last :meth:`pump` stopped at its ``limit``: messages may still wait (this computer is behind the
        #: vehicle: a loaded machine, a stall) until a pump finds none left.
        self.behind = False
        self.closed = False
        self.conn.message_hooks.append(self._on_message)
        self.mav.set_send_callback(self._on_send)

    # --- logging -----------------------------------------------------------------------------------------
    def _on_send(self, msg: Any) -> None:
        buf = msg.get_msgbuf()
        if self.tlog is not None:
            self.tlog.write(buf, LINK_SENT)
        if self.taps:
            # Taps see what the vehicle receives (float32 fields), exactly as a tlog replay will.
            wire = self._decoder.decode(bytearray(buf))
            for tap in list(self.taps):
                tap(wire, True)

    def _on_message(self, _conn: Any, msg: Any) -> None:
        if msg.get_type() == "BAD_DATA":
            return  # garbage is not a packet; logging it would make the tlog unreadable
        header = getattr(msg, "_header", None)
        if header is not None and header.incompat_flags & mavlink.MAVLINK_IFLAG_SIGNED:
            self.signed_seen = True
        if msg.get_type() == "RADIO_STATUS":
            self.radio_heard = True
        if self.tlog is not None:
            self.tlog.write(msg.get_msgbuf(), LINK_RECEIVED)
        for tap in list(self.taps):
            tap(msg, False)

    # --- sending -------------------------------------------------------------------------------------------
    def send(self, msg: Any) -> None:
        if self.closed:
            raise VehicleError("link is closed")
        try:
            self.mav.send(msg)
        except OSError as exc:
            raise VehicleError(f"send failed on {self.endpoint}: {exc}") from None

    def _own_heartbeat(self) -> None:
        now = time.monotonic()
        if now >= self._next_own_heartbeat:
            self._next_own_heartbeat = now + 1.0
            self.send(self.mav.heartbeat_encode(MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID, 0, 0,
                                                mavlink.MAV_STATE_ACTIVE))

    # --- receiving -----------------------------------------------------------------------------------------
    def is_vehicle(self, msg: Any) -> bool:
        return self.target_system != 0 and msg.get_srcSystem() == self.target_system \
            and msg.get_srcComponent() == self.target_component

    def pump(self, timeout: float = 0.0, limit: int | None = None) -> int:
        """Receive and dispatch what is available (at most ``limit`` messages), waiting up to ``timeout`` s for the
        first one; returns how many. Behind the vehicle (:attr:`behind`) the idle hooks still run every
        :data:`IDLE_EVERY` messages: a setpoint stream PX4 needs never waits for the whole backlog."""
        self._idle()
        count = 0
        deadline = time.monotonic() + timeout
        while True:
            try:
                msg = self.conn.recv_msg()
            except OSError as exc:
                raise VehicleError(f"receive failed on {self.endpoint}: {exc}") from None
            if msg is None:
                self.behind = False
                remaining = deadline - time.monotonic()
                if count or remaining <= 0:
                    return count
                self.conn.select(min(remaining, 0.02))
                self._idle()
                continue
            if msg.get_type() == "BAD_DATA":
                continue
            count += 1
            self._track(msg)
            for h in list(self.handlers):
                h(msg)
            if count == limit:
                self.behind = True
                return count
            if count % IDLE_EVERY == 0:
                self._idle()

    def _idle(self) -> None:
        self._own_heartbeat()
        for hook in list(self.idle):
            hook()

    def _track(self, msg: Any) -> None:
        if msg.get_type() != "HEARTBEAT":
            return
        if msg.type == MAV_TYPE_GCS or msg.autopilot == MAV_AUTOPILOT_INVALID:
            return  # another ground station, not the vehicle (pymavlink PR #769)
        if self.target_system == 0:
            self.target_system, self.target_component = msg.get_srcSystem(), msg.get_srcComponent()
        if self.is_vehicle(msg):
            self.last_heartbeat = msg
            self.last_heartbeat_wall = time.monotonic()

    def wait(self, predicate: Callable[[Any], Any], timeout: float) -> Any:
        """Pump until ``predicate(msg)`` is truthy for a message from the vehicle; returns it, or None on timeout."""
        found: list[Any] = []

        def grab(msg: Any) -> None:
            if not found and self.is_vehicle(msg) and predicate(msg):
                found.append(msg)

        self.handlers.append(grab)
        try:
            deadline = time.monotonic() + timeout
            while not found:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return None
                self.pump(min(remaining, 0.1))
            return found[0]
        finally:
            self.handlers.remove(grab)

    def wait_heartbeat(self, timeout: float) -> Any:
        """The vehicle's first (or next) heartbeat; :class:`VehicleError` if none arrives in time."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            before = self.last_heartbeat_wall
            self.pump(0.1)
            if self.last_heartbeat_wall > before:
                return self.last_heartbeat
            if self._wrong_key(WRONG_KEY_FRAMES):  # no need to wait out the timeout: nothing will ever verify
                break
        if self._wrong_key(1):  # signed, but not with our key
            sig = self.mav.signing
            raise VehicleError(f"the vehicle's frames on {self.endpoint} are signed with another key than the one "
                               f"from {self.endpoint.signing.source}: wrong signing key ({sig.badsig_count} frames "
                               f"failed the signature check, {sig.goodsig_count} passed)")
        raise VehicleError(f"no vehicle heartbeat on {self.endpoint} within {timeout:g} s "
                           "(is the vehicle running and sending to this address?)")

    def _wrong_key(self, frames: int) -> bool:
        """At least ``frames`` signed frames failed our key's check and none passed it."""
        sig = self.mav.signing
        return self.endpoint.signing is not None and sig.badsig_count >= frames and not sig.goodsig_count

    def heartbeat_age(self) -> float:
        return time.monotonic() - self.last_heartbeat_wall if self.last_heartbeat_wall else float("inf")

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            if self.tlog is not None:
                self.tlog.close()
                self.tlog = None
            try:
                self.conn.close()
            except OSError:
                pass
