"""A check of what the link actually delivers, before arming: message rates, bytes per second, loss from MAVLink
sequence numbers, round-trip time from TIMESYNC, and RADIO_STATUS where a radio reports it.

A trial needs ``LOCAL_POSITION_NED`` at the mission rate (the monitor and the score read it; below 80 % the
tuner would fall behind the vehicle and abort the trial). :func:`verdict` turns the figures into go, or a refusal
in one line that says what the link delivers, what the mission needs and what would help.
"""

from __future__ import annotations

import time
from collections import Counter
from dataclasses import asdict, dataclass, field
from typing import Any

from ksbo_mav.mav.link import Link

#: Below this share of the mission rate the trial cannot be flown (the tuner falls behind the vehicle).
MIN_RATE_SHARE = 0.8
#: Streams a vehicle sends on its own clock; with none of them the vehicle's clock is paused (a lockstep simulator
#: waits for the tuner's steps) and the rates cannot be judged on the ground.
CLOCKED = ("ATTITUDE", "LOCAL_POSITION_NED", "SYSTEM_TIME", "SYS_STATUS", "GLOBAL_POSITION_INT")


@dataclass
class LinkFigures:
    """What arrived from the vehicle during ``seconds`` of wall time."""

    seconds: float
    bytes_per_s: float
    rates_hz: dict[str, float] = field(default_factory=dict)  # messages per second by type
    loss: float = 0.0  # share of the vehicle's frames missing by sequence number
    rtt_ms: float | None = None  # TIMESYNC round trip (None: not answered)
    radio: dict[str, int] | None = None  # last RADIO_STATUS: rssi, remrssi, noise, remnoise, txbuf, rxerrors
    reduced_from_hz: int | None = None  # the profile's mission rate, when the campaign flies at a lower one

    def to_dict(self) -> dict[str, Any]:
        return {k: (round(v, 3) if isinstance(v, float) else v) for k, v in asdict(self).items()}

    def sent_hz(self, name: str) -> float:
        """How often the vehicle *sends* ``name``, estimated: what arrived, scaled by the share of the vehicle's
        frames its sequence numbers say were lost (a full link drops the frames of every stream alike). On a link
        that loses most frames a stream sent at 4 Hz arrives at 1 Hz; judged by arrival it would look quiet."""
        return self.rates_hz.get(name, 0.0) / max(1.0 - self.loss, 0.05)

    @property
    def sent_bytes_per_s(self) -> float:
        """What the vehicle sends toward us per second, estimated as :meth:`sent_hz` (bytes)."""
        return self.bytes_per_s / max(1.0 - self.loss, 0.05)

    def describe(self) -> str:
        name = "LOCAL_POSITION_NED" if self.rates_hz.get("LOCAL_POSITION_NED", 0.0) > 0 else "ATTITUDE"
        lpn = self.rates_hz.get(name, 0.0)
        rtt = "n/a" if self.rtt_ms is None else f"{self.rtt_ms:.0f} ms"
        paused = not any(self.rates_hz.get(k, 0.0) > 0 for k in CLOCKED)
        return (f"{name} {lpn:.1f} Hz, downlink {self.bytes_per_s / 1000:.2f} kB/s, "
                f"loss {self.loss:.0%}, round trip {rtt}" + (f", radio txbuf {self.radio['txbuf']} %"
                                                              if self.radio else "")
                + ("; the vehicle's clock was paused (lockstep simulator): rates not judged" if paused else ""))


def measure(link: Link, seconds: float = 3.0) -> LinkFigures:
    """Listen for ``seconds`` (the streams already requested) and send one TIMESYNC a second."""
    counts: Counter[str] = Counter()
    size = [0]
    last_seq: dict[tuple[int, int], int] = {}
    gaps, frames = [0], [0]
    sent_ts: dict[int, float] = {}
    rtts: list[float] = []
    radio: list[Any] = []

    def on_msg(msg: Any) -> None:
        kind = msg.get_type()
        if kind == "RADIO_STATUS":  # from the radio itself (a SiK radio is system 51), not from the vehicle
            radio.append(msg)
            return
        if not link.is_vehicle(msg):
            return
        counts[kind] += 1
        size[0] += len(msg.get_msgbuf())
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        seq = msg.get_seq()
        if src in last_seq:
            gaps[0] += (seq - last_seq[src] - 1) % 256
        last_seq[src] = seq
        frames[0] += 1
        if kind == "TIMESYNC" and msg.tc1 != 0 and int(msg.ts1) in sent_ts:
            rtts.append((time.monotonic() - sent_ts.pop(int(msg.ts1))) * 1000.0)

    link.handlers.append(on_msg)
    t0 = time.monotonic()
    next_sync = t0
    try:
        while (now := time.monotonic()) - t0 < seconds:
            if now >= next_sync:
                ts = time.monotonic_ns()
                sent_ts[ts] = now
                link.send(link.mav.timesync_encode(0, ts))
                next_sync = now + 1.0
            link.pump(0.02)
    finally:
        link.handlers.remove(on_msg)
    dt = max(time.monotonic() - t0, 1e-3)
    r = radio[-1] if radio else None
    return LinkFigures(
        seconds=dt, bytes_per_s=size[0] / dt, rates_hz={k: n / dt for k, n in sorted(counts.items())},
        loss=gaps[0] / max(gaps[0] + frames[0], 1), rtt_ms=sorted(rtts)[len(rtts) // 2] if rtts else None,
        radio=None if r is None else {k: int(getattr(r, k)) for k in ("rssi", "remrssi", "noise", "remnoise",
                                                                      "txbuf", "rxerrors")})


def judged(fig: LinkFigures) -> bool:
    """Whether the vehicle streamed anything on its own clock during the measurement."""
    return any(fig.rates_hz.get(k, 0.0) > 0 for k in CLOCKED)


def judged_stream(fig: LinkFigures) -> str:
    """The stream the verdict goes by: LOCAL_POSITION_NED, or ATTITUDE (requested at the same rate) while the
    vehicle has no position estimate yet (an autopilot on the ground before its EKF has an origin sends none)."""
    return "LOCAL_POSITION_NED" if fig.rates_hz.get("LOCAL_POSITION_NED", 0.0) > 0 else "ATTITUDE"


def verdict(fig: LinkFigures, mission_rate_hz: float) -> str | None:
    """None when the link carries what a trial needs, else the one-line reason to refuse. It refuses only on
    evidence that the link is the limit: the judged stream below 80 % of the mission rate *and* frames lost (a
    full buffer or a noisy link) or a radio's buffer nearly full. A slow stream without such evidence (another
    ground station busy, a paused simulator clock) is not the link's fault and is only reported."""
    name = judged_stream(fig)
    rate = fig.rates_hz.get(name, 0.0)
    if rate >= MIN_RATE_SHARE * mission_rate_hz or not judged(fig):
        return None
    radio_full = fig.radio is not None and fig.radio["txbuf"] < 30
    if not (fig.loss > 0.02 or radio_full):
        return None
    # bytes of downlink per sample of the stream (a stream starved by a full link makes the ratio meaningless: at most
    # the mission's own messages, LOCAL_POSITION_NED, ATTITUDE and ACTUATOR_OUTPUT_STATUS, about 230 bytes)
    per_sample = min(fig.bytes_per_s / rate, 230.0) if rate > 0 else 80.0
    need = per_sample * mission_rate_hz
    return (f"link check: the link delivers {fig.describe()}; a trial needs {name} at {mission_rate_hz:g} Hz "
            f"(about {need / 1000:.1f} kB/s down): use a faster link (a wired companion computer, a faster radio "
            "air rate), close other ground stations on it, or fly a profile with a lower mission rate "
            "(docs/links.md); nothing was written to the vehicle")


#: Below this free share of the ground radio's buffer while setpoints stream, the uplink cannot carry the rate.
UPLINK_MIN_FREE = 50
#: SET_POSITION_TARGET_LOCAL_NED with every field ignored (a probe the autopilot stores or drops, never flies).
MASK_IGNORE_ALL = 0x0DFF


def probe_uplink(link: Link, rate_hz: float, seconds: float) -> int | None:
    """Stream setpoints as large as the mission's (every field ignored) at ``rate_hz`` for ``seconds`` and return
    the least free share of the ground radio's buffer (RADIO_STATUS ``txbuf``) it reported meanwhile, or None when
    no radio reports. The downlink measurement cannot see the uplink; a radio that reports its buffer can."""
    seen: list[int] = []

    def on_msg(msg: Any) -> None:
        if msg.get_type() == "RADIO_STATUS":
            seen.append(int(msg.txbuf))

    link.handlers.append(on_msg)
    t0 = next_at = time.monotonic()
    try:
        while (now := time.monotonic()) - t0 < seconds:
            if now >= next_at:
                link.send(link.mav.set_position_target_local_ned_encode(
                    int((now - t0) * 1000), link.target_system, link.target_component, 1, MASK_IGNORE_ALL,
                    1.0, 1.0, -1.0, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1))
                next_at += 1.0 / rate_hz
            link.pump(0.005)
    finally:
        link.handlers.remove(on_msg)
    return min(seen[1:] or seen) if seen else None


#: What a campaign listens to (the mission's streams, the pack and wind, the guard's NAMED_VALUE_FLOAT, the
#: validation mission's progress, what it asks for once, the services' answers): never asked down. One list: a
#: reader of another message adds it here. (TIMESYNC is not: the round trip is measured with our own requests, which
#: the vehicle answers at any rate.)
NEEDED = frozenset({"LOCAL_POSITION_NED", "ATTITUDE", "ACTUATOR_OUTPUT_STATUS", "HEARTBEAT", "SYS_STATUS",
                    "BATTERY_STATUS", "WIND", "WIND_COV", "STATUSTEXT", "COMMAND_ACK", "PARAM_VALUE",
                    "RADIO_STATUS", "FILE_TRANSFER_PROTOCOL", "AUTOPILOT_VERSION", "EXTENDED_SYS_STATE",
                    "NAMED_VALUE_FLOAT", "MISSION_ITEM_REACHED", "MISSION_ACK", "MISSION_COUNT", "MISSION_REQUEST",
                    "MISSION_REQUEST_INT", "MISSION_ITEM_INT", "GPS_GLOBAL_ORIGIN"})

#: Kept at a low rate (Hz) when the link is full rather than stopped: a ground station's picture of the vehicle
#: (its map, fix, HUD and mission progress; HEARTBEAT, ATTITUDE and SYS_STATUS come anyway; the validation's AUTO
#: mission reads MISSION_CURRENT too, for which once a second is enough) and what the campaign asks for once (the
#: hold's stick check reads RC_CHANNELS, the mission's frame HOME_POSITION: PX4 answers a request for a message
#: only while its stream exists).
GROUND_PICTURE = {"GLOBAL_POSITION_INT": 1.0, "GPS_RAW_INT": 1.0, "VFR_HUD": 1.0, "MISSION_CURRENT": 1.0,
                  "RC_CHANNELS": 0.2, "HOME_POSITION": 0.2}


def needed_streams(mission_kind: str) -> frozenset[str]:
    """:data:`NEEDED` for a mission of ``mission_kind``: ACTUATOR_OUTPUT_STATUS (136 bytes a frame; PX4 streams it
    at several Hz on a radio link) is read by the planar task (figure8-xz) only."""
    return NEEDED if mission_kind == "figure8-xz" else NEEDED - {"ACTUATOR_OUTPUT_STATUS"}
