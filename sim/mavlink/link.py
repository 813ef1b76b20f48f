"""Sockets of the endpoint (UDP or TCP server, optional fixed UDP outputs) with fault injection.

UDP behaves like SITL's ``udpin``: the endpoint listens and answers every address that has talked to it in the
last :data:`PEER_TTL_S` seconds (so a test can open a second "pilot" link next to the client); ``--out`` adds
fixed destinations for ground stations that only listen. TCP accepts any number of clients. Each peer has its
own MAVLink parser, so garbage from one peer cannot corrupt another's stream; malformed frames are dropped.

Faults (all switchable at run time through the SIM_* parameters): drop a fraction of incoming / outgoing
messages, delay outgoing messages, or go completely silent (neither receive nor send) for a while.
"""

from __future__ import annotations

import heapq
import itertools
import select
import socket
import time
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mavlink

PEER_TTL_S = 60.0
_MAX_DATAGRAM = 65535
_BATCH_BYTES = 1200  # keep datagrams below a typical MTU


@dataclass
class Faults:
    loss_in: float = 0.0  # probability of dropping each received message
    loss_out: float = 0.0  # probability of dropping each sent message
    delay_s: float = 0.0  # added latency of every sent message (wall clock)
    mute_until: float = 0.0  # wall-clock time until which nothing is received or sent
    hb_mute_until: float = 0.0  # wall-clock time until which no HEARTBEAT is sent (the rest still is)


def _is_heartbeat(buf: bytes) -> bool:
    """A packed HEARTBEAT (message id 0), MAVLink 2 or 1."""
    return (buf[0] == 0xFD and len(buf) > 9 and buf[7:10] == b"\0\0\0") or (buf[0] == 0xFE and len(buf) > 5
                                                                            and buf[5] == 0)


def _parser() -> mavlink.MAVLink:
    p = mavlink.MAVLink(None)
    p.robust_parsing = True  # bad CRC / garbage become BAD_DATA messages instead of exceptions
    return p


class Link:
    """A listening UDP or TCP endpoint. ``kind`` is "udp" or "tcp"."""

    def __init__(self, kind: str, host: str, port: int, outs: list[tuple[str, int]] | None = None,
                 seed: int | None = None) -> None:
        self.kind = kind
        self.faults = Faults()
        self._rng = np.random.default_rng(seed)
        self._outs = list(outs or [])
        self._parsers: dict[object, mavlink.MAVLink] = {}
        self._peers: dict[tuple[str, int], float] = {}  # UDP address -> last heard (wall)
        self._clients: dict[socket.socket, object] = {}
        self._delayed: list[tuple[float, int, bytes]] = []
        self._batch: list[bytes] = []  # messages written since the last flush()
        self._batch_len = 0
        self._tie = itertools.count()
        self.received = self.dropped_in = self.sent = self.dropped_out = 0
        if kind == "udp":
            self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 1 << 20)
        elif kind == "tcp":
            self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        else:
            raise ValueError(kind)
        self.sock.bind((host, port))
        if kind == "tcp":
            self.sock.listen(4)
        self.sock.setblocking(False)

    @property
    def address(self) -> tuple[str, int]:
        return self.sock.getsockname()[:2]

    def close(self) -> None:
        self.flush()
        for c in list(self._clients):
            c.close()
        self.sock.close()

    # --- receive ---------------------------------------------------------------------------------------
    def poll(self, timeout: float) -> Iterator[mavlink.MAVLink_message]:
        """Wait up to ``timeout`` s for input; yield every complete, valid message received."""
        now = time.monotonic()
        if self._delayed:
            timeout = min(timeout, max(0.0, self._delayed[0][0] - now))
        try:
            ready, _, _ = select.select([self.sock, *self._clients], [], [], max(0.0, timeout))
        except InterruptedError:
            ready = []
        for s in ready:
            for key, data in self._read(s):
                yield from self._parse(key, data)
        self.flush()

    def _read(self, s: socket.socket) -> Iterator[tuple[object, bytes]]:
        if self.kind == "udp":
            for _ in range(256):  # drain a burst without starving the simulation
                try:
                    data, addr = self.sock.recvfrom(_MAX_DATAGRAM)
                except (BlockingIOError, InterruptedError):
                    return
                except OSError:  # ICMP port unreachable from a vanished peer, etc.
                    return
                if time.monotonic() >= self.faults.mute_until:
                    self._peers[addr] = time.monotonic()
                yield addr, data
        elif s is self.sock:
            try:
                conn, addr = self.sock.accept()
            except OSError:
                return
            conn.setblocking(True)
            conn.settimeout(1.0)
            self._clients[conn] = addr
        else:
            try:
                s.setblocking(False)
                data = s.recv(_MAX_DATAGRAM)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                data = b""
            finally:
                s.settimeout(1.0)
            if not data:
                self._drop_client(s)
                return
            yield s, data

    def _parse(self, key: object, data: bytes) -> Iterator[mavlink.MAVLink_message]:
        parser = self._parsers.setdefault(key, _parser())
        try:
            msgs = parser.parse_buffer(data) or []
        except Exception:  # a hostile byte stream must never take the vehicle down
            self._parsers[key] = _parser()
            return
        muted = time.monotonic() < self.faults.mute_until
        for m in msgs:
            if m.get_type() == "BAD_DATA":
                continue
            self.received += 1
            if muted or (self.faults.loss_in > 0 and self._rng.random() < self.faults.loss_in):
                self.dropped_in += 1
                continue
            yield m

    def _drop_client(self, s: socket.socket) -> None:
        self._clients.pop(s, None)
        self._parsers.pop(s, None)
        s.close()

    # --- send ------------------------------------------------------------------------------------------
    def write(self, buf: bytes) -> None:
        """File-like sink for pymavlink's ``MAVLink.send``: one call per packed message (sent on flush())."""
        self.sent += 1
        f = self.faults
        now = time.monotonic()
        if now < f.mute_until or (f.loss_out > 0 and self._rng.random() < f.loss_out) or \
                (now < f.hb_mute_until and _is_heartbeat(buf)):
            self.dropped_out += 1
            return
        if f.delay_s > 0:
            heapq.heappush(self._delayed, (now + f.delay_s, next(self._tie), bytes(buf)))
            return
        self._batch.append(bytes(buf))
        self._batch_len += len(buf)
        if self._batch_len > _BATCH_BYTES:
            self.flush()

    def flush(self) -> None:
        """Send what was written since the last flush (one datagram, as ArduPilot packs its UDP output) and the
        delayed messages whose time has come."""
        if self._batch:
            self._transmit(b"".join(self._batch))
            self._batch.clear()
            self._batch_len = 0
        now = time.monotonic()
        while self._delayed and self._delayed[0][0] <= now:
            self._transmit(heapq.heappop(self._delayed)[2])

    def _transmit(self, buf: bytes) -> None:
        if self.kind == "udp":
            now = time.monotonic()
            for addr, seen in list(self._peers.items()):
                if now - seen > PEER_TTL_S:
                    del self._peers[addr]
                    self._parsers.pop(addr, None)
                    continue
                self._sendto(buf, addr)
            for addr in self._outs:
                if addr not in self._peers:
                    self._sendto(buf, addr)
        else:
            for c in list(self._clients):
                try:
                    c.sendall(buf)
                except OSError:
                    self._drop_client(c)

    def _sendto(self, buf: bytes, addr: tuple[str, int]) -> None:
        try:
            self.sock.sendto(buf, addr)
        except OSError:
            pass  # full buffer or unreachable peer: a lost packet, as on a radio link

    @property
    def has_peers(self) -> bool:
        return bool(self._peers or self._outs or self._clients)
