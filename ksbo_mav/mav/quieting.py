"""The vehicle's own streams asked down on a full link, from a table of what each stack streams
(:mod:`ksbo_mav.mav.stream_sets`) rather than from what happened to arrive, and put back when the campaign ends.

A link the vehicle overfills loses most of its frames; the streams that fill it are then the ones least likely to
be seen in a few seconds of listening, so judging by arrival quiets the wrong ones. :func:`quiet_plan` asks every
message of the stack's default stream sets that the campaign does not use (:data:`~ksbo_mav.mav.linkcheck.NEEDED`)
to stop, keeps a ground station's picture (:data:`~ksbo_mav.mav.linkcheck.GROUND_PICTURE`) at a low rate, and
slows anything else the vehicle sends fast, judged by sequence numbers. Everything goes by SET_MESSAGE_INTERVAL on
this link only: no parameter changes, another port of the vehicle keeps its streams, and a reboot or
:meth:`StreamQuieter.restore` (interval 0: the autopilot's own rate for that message) puts them back.

Commands go out paced from the link's idle hook, fire and forget: on a full downlink most acknowledgements are lost,
and what the vehicle sends afterwards (its sequence numbers) is the confirmation that counts.
"""

from __future__ import annotations

import re
import time
from collections import deque
from collections.abc import Callable

from typing import Any

from ksbo_mav.errors import VehicleError
from ksbo_mav.mav.commands import CMD_INTERVAL, Commander
from ksbo_mav.mav.link import Link
from ksbo_mav.mav.linkcheck import GROUND_PICTURE, NEEDED, LinkFigures
from ksbo_mav.mav.stream_sets import all_messages, group_of, message_id

#: Bytes of one SET_MESSAGE_INTERVAL on the uplink (COMMAND_LONG, MAVLink 2 with its trailing zeros cut).
COMMAND_BYTES = 45
#: Commands per second: between these, half of what the link was measured to carry down (the uplink of a radio
#: is no faster, and setpoints may share it).
MIN_PACE_HZ, MAX_PACE_HZ = 5.0, 40.0
#: While connecting: the share of the vehicle's frames lost by sequence number (over at least this many frames)
#: above which its streams are asked down before the parameters are downloaded.
CONNECT_LOSS, CONNECT_FRAMES = 0.3, 20
#: Commands per second while connecting (nothing measured yet): about 450 B/s, which a slow radio's uplink takes.
CONNECT_PACE_HZ = 10.0
#: Messages that arrive as answers to the link check's own requests (a TIMESYNC a second), not as a stream: asking
#: for their interval changes nothing. (PX4's Onboard mode also streams TIMESYNC: the table stops that.)
ANSWERS = frozenset({"TIMESYNC"})
#: ArduPilot's answer to an interval for a message it has no sender for (the id named): not asked again.
REFUSAL = re.compile(r"No ap_message for mavlink id \((\d+)\)")
#: HEARTBEAT.autopilot -> the stack whose table applies (the stack is confirmed later from AUTOPILOT_VERSION).
_STACK_OF_AUTOPILOT = {3: "ardupilot", 12: "px4"}


def quiet_plan(stack_name: str, needed: frozenset[str], fig: LinkFigures | None = None, above_hz: float = 1.1,
               to_hz: float = 1.0, picture_scale: float = 1.0) -> dict[str, float]:
    """{message: rate to ask for, Hz (0: stop)}. Every message of the stack's default stream sets that is not
    ``needed``: stopped, whether or not it arrived, except the ground station's picture (its rate in
    :data:`GROUND_PICTURE` times ``picture_scale``); every other message the vehicle sends (``fig``, by sequence
    numbers: :meth:`LinkFigures.sent_hz`) faster than ``above_hz`` and not ``needed``: ``to_hz``."""
    def rate(name: str, otherwise: float) -> float:
        return GROUND_PICTURE[name] * picture_scale if name in GROUND_PICTURE else otherwise

    plan = {name: rate(name, 0.0) for name in all_messages(stack_name)
            if name not in needed and message_id(name) is not None}
    for name in sorted(fig.rates_hz) if fig is not None else ():
        if (name in needed or name in plan or name in ANSWERS or message_id(name) is None
                or fig.sent_hz(name) <= above_hz):
            continue
        plan[name] = rate(name, to_hz)
    return plan


def arrives_above(fig: LinkFigures, name: str, hz: float) -> bool:
    """Whether ``name`` arrived in ``fig`` clearly faster than the ``hz`` it was asked down to (0: stopped)."""
    return fig.rates_hz.get(name, 0.0) > 1.5 * hz + 0.1


def pace_for(fig: LinkFigures | None) -> float:
    """Commands per second for a link whose downlink carried ``fig.bytes_per_s`` (half of it, bounded)."""
    if fig is None or fig.bytes_per_s <= 0:
        return MAX_PACE_HZ
    return max(MIN_PACE_HZ, min(MAX_PACE_HZ, 0.5 * fig.bytes_per_s / COMMAND_BYTES))


class StreamQuieter:
    """The message intervals this tool asked of the vehicle on this link to make room, sent paced from the link's
    idle hook, and put back (interval 0) by :meth:`restore`."""

    def __init__(self, cmd: Commander, stack_name: str) -> None:
        self.cmd, self.stack_name = cmd, stack_name
        #: {message: rate asked, Hz (0: stopped)} since the last restore
        self.asked: dict[str, float] = {}
        self._queue: deque[tuple[int, float]] = deque()  # (message id, interval µs) still to send
        self._gap_s = 1.0 / MAX_PACE_HZ
        self._next_at = 0.0
        #: monotonic time the last queued command went out (frames the vehicle queued before it still arrive)
        self.last_sent = 0.0
        self.log: Callable[[str], None] = lambda s: None
        #: message ids the vehicle said it cannot send (not asked again: each refusal costs a STATUSTEXT down)
        self.refused: set[int] = set()
        #: messages asked down and then measured quiet: one arriving fast again was asked for by someone else
        self.quiet_seen: set[str] = set()
        #: whether the console was told that a ground station asks for its streams again
        self.gcs_said = False
        cmd.link.idle.append(self._drain)
        cmd.link.handlers.append(self._on_msg)

    def _on_msg(self, msg: Any) -> None:
        if msg.get_type() == "STATUSTEXT" and self.cmd.link.is_vehicle(msg):
            m = REFUSAL.search(str(msg.text))
            if m:
                self.refused.add(int(m.group(1)))

    def note_quiet(self, fig: LinkFigures) -> None:
        """Remember which messages asked down the measurement ``fig`` found at (or below) their asked rate."""
        self.quiet_seen.update(n for n, hz in self.asked.items() if not arrives_above(fig, n, hz))

    @property
    def busy(self) -> bool:
        return bool(self._queue)

    def ask(self, rates: dict[str, float], pace_hz: float = MAX_PACE_HZ,
            lead: list[tuple[int, float]] | None = None) -> None:
        """Queue SET_MESSAGE_INTERVAL for each of ``rates`` (0 Hz: -1, stop), after the ``lead`` commands ((message
        id, interval µs): the mission's own streams, re-asserted first), at ``pace_hz`` commands a second."""
        self._gap_s = 1.0 / max(pace_hz, 0.1)
        self._queue.extend(c for c in lead or [] if c[0] not in self.refused)
        for name, hz in rates.items():
            mid = message_id(name)
            if mid is None or mid in self.refused:
                continue
            self._queue.append((mid, -1.0 if hz <= 0 else 1e6 / hz))
            self.asked[name] = hz

    def _drain(self) -> None:
        now = time.monotonic()
        if self._next_at < now - self._gap_s:
            self._next_at = now
        while self._queue and now >= self._next_at:
            mid, interval_us = self._queue.popleft()
            try:
                self.cmd.send(CMD_INTERVAL, mid, interval_us)
            except VehicleError:  # a closed or broken link: nothing more can be asked on it
                self._queue.clear()
                return
            self.last_sent = now
            self._next_at += self._gap_s

    def flush(self, timeout_s: float = 30.0) -> bool:
        """Pump the link until every queued command went out (True), or ``timeout_s`` passed."""
        deadline = time.monotonic() + timeout_s
        while self._queue and time.monotonic() < deadline:
            self.cmd.link.pump(min(self._gap_s, 0.05))
        return not self._queue

    def restore(self, timeout_s: float = 15.0) -> list[str]:
        """Ask each message asked down for the autopilot's own rate again (interval 0: ArduPilot the rate of its
        stream group, PX4 the default of the port's mode, as before the campaign), at the pace last used; returns
        their names."""
        names = list(self.asked)
        self._queue.clear()
        if names:
            self._queue.extend((mid, 0.0) for mid in (message_id(n) for n in names)
                               if mid is not None and mid not in self.refused)
            done = self.flush(timeout_s)
            self.log(f"link: asked the vehicle for its own rates of the {len(names)} messages asked down on this "
                     "link" + ("" if done else " (not all sent: a reboot restores them)"))
        self.asked.clear()
        return names


def describe_asked(stack_name: str, fig: LinkFigures, changed: dict[str, float]) -> str:
    """The console line for one round of asking the streams down."""
    stopped = [n for n, hz in changed.items() if hz == 0]
    slowed: dict[float, list[str]] = {}
    for n, hz in changed.items():
        if hz > 0:
            slowed.setdefault(hz, []).append(n)
    groups = sorted({g for g in (group_of(stack_name, n) for n in stopped) if g})
    where = {"ardupilot": f"of ArduPilot's stream groups {', '.join(groups)}",
             "px4": "of PX4's default streams"}.get(stack_name, "of its default streams")
    parts = []
    if stopped:
        names = f" ({', '.join(stopped)})" if len(stopped) <= 8 else ""
        parts.append(f"to stop {len(stopped)} messages {where} the campaign does not use{names}, whether or not "
                     "they arrived")
    parts += [f"to send {', '.join(names)} {_every(hz)}" for hz, names in sorted(slowed.items(), reverse=True)]
    if fig.seconds:
        why = (f"the vehicle sends about {fig.sent_bytes_per_s / 1000:.1f} kB/s, {fig.bytes_per_s / 1000:.1f} "
               f"arrive ({fig.loss:.0%} of its frames lost by sequence number)")
    else:
        why = f"{fig.loss:.0%} of the vehicle's frames lost by sequence number while connecting"
    return (f"link: {why}: asked it, on this link, " + "; and ".join(parts)
            + " (no parameter changed; put back when the campaign ends)")


def _every(hz: float) -> str:
    return "once a second" if hz == 1.0 else f"once every {1 / hz:g} s"


class SequenceLoss:
    """Frames and sequence gaps per sender on a link, from construction until :meth:`stop`."""

    def __init__(self, link: Link) -> None:
        self.link = link
        self.frames: dict[tuple[int, int], int] = {}
        self.gaps: dict[tuple[int, int], int] = {}
        self._last: dict[tuple[int, int], int] = {}
        link.handlers.append(self._on_msg)

    def _on_msg(self, msg: Any) -> None:
        src, seq = (msg.get_srcSystem(), msg.get_srcComponent()), msg.get_seq()
        if src in self._last:
            self.gaps[src] = self.gaps.get(src, 0) + (seq - self._last[src] - 1) % 256
        self._last[src] = seq
        self.frames[src] = self.frames.get(src, 0) + 1

    def share(self, src: tuple[int, int]) -> tuple[float, int]:
        """(share of ``src``'s frames lost, frames received)."""
        n, g = self.frames.get(src, 0), self.gaps.get(src, 0)
        return g / max(n + g, 1), n

    def stop(self) -> None:
        if self._on_msg in self.link.handlers:
            self.link.handlers.remove(self._on_msg)


def quiet_while_connecting(cmd: Commander, autopilot: int, seen: SequenceLoss,
                           log: Callable[[str], None]) -> StreamQuieter:
    """The vehicle's quieter; when the frames seen so far say the link is full (more than :data:`CONNECT_LOSS`
    lost), its default streams are asked down at once, so that the parameter download and the link check run on
    a link that carries them."""
    stack_name = _STACK_OF_AUTOPILOT.get(autopilot, "ksbo-sim")
    quieter = StreamQuieter(cmd, stack_name)
    quieter.log = log
    link = cmd.link
    loss, frames = seen.share((link.target_system, link.target_component))
    if frames >= CONNECT_FRAMES and loss > CONNECT_LOSS:
        plan = quiet_plan(stack_name, NEEDED)
        quieter.ask(plan, CONNECT_PACE_HZ)
        quieter.flush()
        log(describe_asked(stack_name, LinkFigures(seconds=0.0, bytes_per_s=0.0, loss=loss), plan))
    return quieter
