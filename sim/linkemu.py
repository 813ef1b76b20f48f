"""A link emulator process: a MAVLink proxy between a vehicle and a ground station that shapes the traffic like a
telemetry radio (:mod:`ksbo_sim.linkshape`).

    python -m ksbo_sim.linkemu --vehicle udpin:127.0.0.1:14541 --ground udp:127.0.0.1:14600 \\
        --shape down=4000,up=2000,queue=1024,loss=0.05

Vehicle side: ``udpin:HOST:PORT`` (bind; the vehicle sends here, replies go to the address it sent from, from this
same socket — PX4 keeps the partner address it last heard from), ``udp:HOST:PORT`` (send to the vehicle, e.g. our
simulator's own port) or ``tcp:HOST:PORT`` (connect, e.g. ArduPilot SITL's 5760; the stream is cut into frames).
Ground side: ``udp:HOST:PORT`` (send to a ground station listening there: ``ksbo-mav tune --udp HOST:PORT``) or
``udpin:HOST:PORT`` (bind; the ground station sends first: ``--udpout``). Port 0 binds a free port.

It prints one ready line, ``ksbo-linkemu ready vehicle:PORT ground:PORT``, then forwards until killed; on SIGTERM
it prints the counters of both directions as one JSON line (``ksbo-linkemu stats {...}``). SIGUSR1 cuts the link
(every frame either way, and those already on their way, is dropped: a radio out of range) until SIGUSR2; the
frames a cut dropped are counted as ``cut``.
"""

from __future__ import annotations

import argparse
import json
import select
import signal
import socket
import sys
import time

from ksbo_sim.errors import SimInputError
from ksbo_sim.linkshape import LinkShape, Pipe, pipes

V1, V2 = 0xFE, 0xFD


def split_frames(buf: bytearray) -> list[bytes]:
    """Remove and return the complete MAVLink v1/v2 frames at the head of ``buf`` (a TCP stream); bytes before a
    frame start are skipped, an incomplete frame stays."""
    out = []
    while buf:
        start = next((i for i, b in enumerate(buf) if b in (V1, V2)), None)
        if start is None:
            buf.clear()
            break
        del buf[:start]
        if len(buf) < 3:
            break
        n = buf[1] + (8 if buf[0] == V1 else 12 + (13 if len(buf) > 2 and buf[2] & 1 else 0))
        if len(buf) < n:
            break
        out.append(bytes(buf[:n]))
        del buf[:n]
    return out


class Side:
    """One end of the proxy: a socket, and where frames to that end go."""

    def __init__(self, spec: str, what: str) -> None:
        kind, _, rest = spec.partition(":")
        host, _, port = rest.rpartition(":")
        if kind not in ("udp", "udpin", "tcp") or not host or not port.isdigit():
            raise SimInputError(f"--{what} {spec!r}: expected udp:HOST:PORT, udpin:HOST:PORT or tcp:HOST:PORT")
        self.kind, self.buf = kind, bytearray()
        self.peer: tuple[str, int] | None = None
        if kind == "tcp":
            self.sock = socket.create_connection((host, int(port)), timeout=10.0)
            self.sock.setblocking(False)
            self.port = self.sock.getsockname()[1]
            return
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        if kind == "udpin":
            self.sock.bind((host, int(port)))
        else:
            self.sock.bind((host, 0))
            self.peer = (host, int(port))
        self.sock.setblocking(False)
        self.port = self.sock.getsockname()[1]

    def receive(self) -> list[bytes]:
        """MAVLink frames that arrived on this side (datagrams and the TCP stream are cut into frames)."""
        if self.kind == "tcp":
            try:
                data = self.sock.recv(65536)
            except BlockingIOError:
                return []
            if not data:
                raise ConnectionError("the vehicle closed the TCP connection")
            self.buf.extend(data)
            return split_frames(self.buf)
        frames = []
        while True:
            try:
                data, addr = self.sock.recvfrom(65536)
            except BlockingIOError:
                return frames
            if self.kind == "udpin":
                self.peer = addr  # the partner it last heard from, as the autopilots do
            # A datagram may carry several frames (our simulator packs a burst): each is a frame on the air.
            frames.extend(split_frames(bytearray(data)) or [data])

    def send(self, frame: bytes) -> None:
        try:
            if self.kind == "tcp":
                self.sock.sendall(frame)
            elif self.peer is not None:
                self.sock.sendto(frame, self.peer)
        except (BlockingIOError, ConnectionRefusedError):
            pass  # nobody listening yet on the other end: the frame is lost, as over the air


def _stats(down: Pipe, up: Pipe, cut: dict[str, int]) -> str:
    def d(p: Pipe, name: str) -> dict[str, int]:
        return {"frames": p.sent, "bytes": p.sent_bytes, "dropped": p.dropped, "lost": p.lost, "cut": cut[name]}
    return json.dumps({"down": d(down, "down"), "up": d(up, "up")})


class GroundRadio:
    """The ground radio's own RADIO_STATUS, once a second, as a SiK radio sends it (system 51, component 68):
    ``txbuf`` is the free share of its buffer toward the vehicle, which a ground station uses for flow control."""

    def __init__(self) -> None:
        from pymavlink.dialects.v20 import ardupilotmega as mavlink

        self.mav = mavlink.MAVLink(None, srcSystem=51, srcComponent=68)
        self.next_at = 0.0

    def due(self, up: Pipe, now: float) -> bytes | None:
        if now < self.next_at:
            return None
        self.next_at = now + 1.0
        msg = self.mav.radio_status_encode(rssi=180, remrssi=175, txbuf=up.free_percent(now), noise=40,
                                           remnoise=42, rxerrors=0, fixed=0)
        frame = bytes(msg.pack(self.mav))
        self.mav.seq = (self.mav.seq + 1) % 256  # a radio numbers its own frames, as any MAVLink sender
        return frame


def run(vehicle: Side, ground: Side, shape: LinkShape, stop: list[bool], cut: list[bool] | None = None,
        cut_frames: dict[str, int] | None = None) -> tuple[Pipe, Pipe]:
    """Forward frames between the sides through the shaped pipes until ``stop[0]``; while ``cut[0]`` every frame is
    dropped (counted in ``cut_frames``)."""
    down, up = pipes(shape)
    cut = cut if cut is not None else [False]
    cut_frames = cut_frames if cut_frames is not None else {"down": 0, "up": 0}
    socks = {vehicle.sock: (vehicle, down), ground.sock: (ground, up)}
    names = {id(down): "down", id(up): "up"}
    radio = GroundRadio() if shape.radio else None
    while not stop[0]:
        now = time.monotonic()
        status = radio.due(up, now) if radio else None
        if status:
            ground.send(status)  # from the ground radio itself: no air between it and the ground station
        nxt = [t for t in (down.next_due(), up.next_due()) if t is not None]
        wait = max(0.0, min(nxt) - now) if nxt else 0.05
        readable, _, _ = select.select(list(socks), [], [], min(wait, 0.05))
        now = time.monotonic()
        for s in readable:
            _, pipe = socks[s]
            for frame in socks[s][0].receive():
                if cut[0]:
                    cut_frames[names[id(pipe)]] += 1
                else:
                    pipe.push(frame, now)
        for frame in down.due(now):
            if cut[0]:
                cut_frames["down"] += 1
            else:
                ground.send(frame)
        for frame in up.due(now):
            if cut[0]:
                cut_frames["up"] += 1
            else:
                vehicle.send(frame)
    return down, up


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m ksbo_sim.linkemu", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--vehicle", required=True, help="udpin:HOST:PORT, udp:HOST:PORT or tcp:HOST:PORT")
    ap.add_argument("--ground", required=True, help="udp:HOST:PORT or udpin:HOST:PORT")
    ap.add_argument("--shape", default="", help="link shape, e.g. down=4000,up=2000,queue=1024,loss=0.05")
    a = ap.parse_args(argv)
    try:
        shape = LinkShape.parse(a.shape)
        ground = Side(a.ground, "ground")
        vehicle = Side(a.vehicle, "vehicle")
    except (SimInputError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    stop, cut, cut_frames = [False], [False], {"down": 0, "up": 0}
    signal.signal(signal.SIGTERM, lambda *_: stop.__setitem__(0, True))
    signal.signal(signal.SIGINT, lambda *_: stop.__setitem__(0, True))
    signal.signal(signal.SIGUSR1, lambda *_: cut.__setitem__(0, True))
    signal.signal(signal.SIGUSR2, lambda *_: cut.__setitem__(0, False))
    print(f"ksbo-linkemu ready vehicle:{vehicle.port} ground:{ground.port} {shape.describe()}", flush=True)
    try:
        down, up = run(vehicle, ground, shape, stop, cut, cut_frames)
    except ConnectionError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(f"ksbo-linkemu stats {_stats(down, up, cut_frames)}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
