"""The shape of a radio-like link: bandwidth each way (or shared, half-duplex), a queue, latency and jitter,
whole-frame loss and loss bursts. :class:`Pipe` applies it to the frames of one direction.

A SiK-class telemetry radio pair at 57600 baud serial and 64 kbit/s in the air gives a few kB/s each way,
half-duplex, with a buffer of about 1 KB: frames queue at the sender when the air is busy, are dropped when the
buffer is full, and are lost whole (bad CRC) on a noisy link, often in bursts.

Spec (``ksbo-mav sim --link SPEC``, ``python -m ksbo_sim.linkemu --shape SPEC``): comma-separated ``key=value``:
``down`` / ``up`` bytes per second (vehicle → ground / ground → vehicle; 0 = unlimited), ``queue`` bytes of buffer
per direction, ``latency`` and ``jitter`` seconds, ``loss`` probability of a frame being lost, ``burst`` mean
length of a loss burst in frames (1 = independent losses), ``duplex`` ``full`` or ``half`` (half: both directions
share one air time of ``max(down, up)`` bytes per second), ``seed``, ``radio`` (1: the ground radio reports
RADIO_STATUS once a second as a SiK radio does, ``txbuf`` the free share of its uplink buffer). Example:
``down=4000,up=2000,queue=1024,loss=0.05,latency=0.03``. A spec may start with the name of a case of
:data:`CASES` (``sik``: a SiK-class radio without RADIO_STATUS), followed by keys that change it (``sik,loss=0.1``).
"""

from __future__ import annotations

import heapq
import random
from dataclasses import dataclass, field, fields

from ksbo_sim.errors import SimInputError


#: Named links, each a spec. ``sik``: a SiK-class telemetry radio in its raw mode (no RADIO_STATUS, so no
#: flow-control reports) at 2 kB/s (a 64 kbit/s air rate with error correction), half duplex, a small buffer that
#: drops what does not fit, whole frames lost now and then. ``sik-status``: the same radio reporting RADIO_STATUS,
#: as SiK firmware does in its MAVLink mode.
CASES = {"sik": "down=2000,up=2000,duplex=half,queue=1024,latency=0.03,jitter=0.01,loss=0.02,seed=1",
         "sik-status": "down=2000,up=2000,duplex=half,queue=1024,latency=0.03,jitter=0.01,loss=0.02,seed=1,radio=1"}


@dataclass(frozen=True)
class LinkShape:
    """See the module docstring; every default is an ideal link."""

    down: float = 0.0
    up: float = 0.0
    queue: int = 65536
    latency: float = 0.0
    jitter: float = 0.0
    loss: float = 0.0
    burst: float = 1.0
    duplex: str = "full"
    seed: int = 0
    radio: int = 0

    @classmethod
    def parse(cls, spec: str) -> "LinkShape":
        """A shape from ``key=value,...``; SimInputError naming the bad key or value."""
        kinds = {f.name: f.type for f in fields(cls)}
        values: dict[str, object] = {}
        items = [s.strip() for s in spec.split(",") if s.strip()]
        if items and items[0] in CASES:
            items = CASES[items[0]].split(",") + items[1:]
        for item in items:
            key, sep, text = item.partition("=")
            key = key.strip()
            if not sep or key not in kinds:
                raise SimInputError(f"link spec {item!r}: expected KEY=VALUE with KEY one of {', '.join(kinds)}, or "
                                    f"first a case: {', '.join(CASES)}")
            try:
                values[key] = text.strip() if key == "duplex" else (int(text) if kinds[key] == "int"
                                                                    else float(text))
            except ValueError:
                raise SimInputError(f"link spec {item!r}: {text!r} is not a number") from None
        shape = cls(**values)  # type: ignore[arg-type]
        shape.check()
        return shape

    def check(self) -> None:
        if min(self.down, self.up, self.latency, self.jitter) < 0 or self.queue < 64:
            raise SimInputError("link spec: rates, latency and jitter must be >= 0 and queue >= 64 bytes")
        if not 0.0 <= self.loss < 1.0 or self.burst < 1.0:
            raise SimInputError("link spec: loss must be in [0, 1) and burst >= 1")
        if self.radio not in (0, 1):
            raise SimInputError(f"link spec: radio must be 0 or 1, got {self.radio}")
        if self.duplex not in ("full", "half"):
            raise SimInputError(f"link spec: duplex must be full or half, got {self.duplex!r}")

    def describe(self) -> str:
        def rate(r: float) -> str:
            return "unlimited" if r <= 0 else f"{r / 1000:g} kB/s"
        return (f"down {rate(self.down)}, up {rate(self.up)}, {self.duplex} duplex, queue {self.queue} B, "
                f"latency {self.latency * 1000:g}±{self.jitter * 1000:g} ms, loss {self.loss:.0%}"
                + (f" in bursts of {self.burst:g}" if self.burst > 1 else "")
                + (", the ground radio reports RADIO_STATUS" if self.radio else ""))


@dataclass
class Air:
    """Air time of a link: when the channel is next free (shared by both pipes of a half-duplex link)."""

    free_at: float = 0.0


@dataclass
class Pipe:
    """One direction: frames enter with :meth:`push`, leave with :meth:`due` once sent and delayed.

    Counters: ``sent`` frames and bytes delivered, ``dropped`` (queue full) and ``lost`` (the air)."""

    rate: float
    queue: int
    latency: float
    jitter: float
    loss: float
    burst: float
    air: Air
    rng: random.Random
    _queued: list[tuple[float, int]] = field(default_factory=list)  # (departure time, bytes) not yet departed
    _out: list[tuple[float, int, bytes]] = field(default_factory=list)  # heap of (arrival time, seq, frame)
    _seq: int = 0
    _in_burst: bool = False
    sent: int = 0
    sent_bytes: int = 0
    dropped: int = 0
    lost: int = 0

    def backlog(self, now: float) -> int:
        """Bytes waiting for the air at ``now``."""
        self._queued = [(t, n) for t, n in self._queued if t > now]
        return sum(n for _, n in self._queued)

    def push(self, frame: bytes, now: float) -> None:
        """Offer a frame at time ``now`` (seconds, monotonic)."""
        if self.rate > 0 and self.backlog(now) + len(frame) > self.queue:
            self.dropped += 1
            return
        start = max(now, self.air.free_at) if self.rate > 0 else now
        depart = start + (len(frame) / self.rate if self.rate > 0 else 0.0)
        if self.rate > 0:
            self.air.free_at = depart
            self._queued.append((depart, len(frame)))
        if self._lose():
            self.lost += 1
            return
        arrive = depart + self.latency + (self.rng.uniform(0.0, self.jitter) if self.jitter > 0 else 0.0)
        # Frames of one direction never overtake each other (a radio is a FIFO): jitter only delays.
        if self._out:
            arrive = max(arrive, max(t for t, _, _ in self._out))
        self._seq += 1
        heapq.heappush(self._out, (arrive, self._seq, frame))

    def _lose(self) -> bool:
        """Gilbert-style loss: independent at ``loss``; once lost, the next is lost with 1 − 1/burst."""
        if self._in_burst and self.rng.random() < 1.0 - 1.0 / self.burst:
            return True
        self._in_burst = self.rng.random() < self.loss
        return self._in_burst

    def due(self, now: float) -> list[bytes]:
        """Frames that have arrived by ``now``, in order."""
        out = []
        while self._out and self._out[0][0] <= now:
            _, _, frame = heapq.heappop(self._out)
            out.append(frame)
            self.sent += 1
            self.sent_bytes += len(frame)
        return out

    def next_due(self) -> float | None:
        return self._out[0][0] if self._out else None

    def free_percent(self, now: float) -> int:
        """The free share of the buffer at ``now`` (100 for an unlimited pipe): a SiK radio's ``txbuf``."""
        return 100 if self.rate <= 0 else max(0, min(100, int(100 * (1 - self.backlog(now) / self.queue))))


def pipes(shape: LinkShape) -> tuple[Pipe, Pipe]:
    """(downlink, uplink) pipes of ``shape``; half duplex: one shared air time at the faster direction's rate."""
    rng = random.Random(shape.seed)
    if shape.duplex == "half":
        air = Air()
        rate = max(shape.down, shape.up)
        down_rate = up_rate = rate
        down_air = up_air = air
    else:
        down_rate, up_rate, down_air, up_air = shape.down, shape.up, Air(), Air()
    common = dict(queue=shape.queue, latency=shape.latency, jitter=shape.jitter, loss=shape.loss, burst=shape.burst,
                  rng=rng)
    return Pipe(rate=down_rate, air=down_air, **common), Pipe(rate=up_rate, air=up_air, **common)
