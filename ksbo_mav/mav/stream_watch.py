"""A ground station sharing the link that asks for its streams again, noticed while the campaign flies.

Mission Planner asks the vehicle for its stream rates (REQUEST_DATA_STREAM) when it connects and again whenever the
rates it receives differ from its settings, MAVProxy every 15 s, QGroundControl when it connects. On ArduPilot each
request resets a whole stream group, undoing what :mod:`ksbo_mav.mav.quieting` asked, and the link fills again.
:class:`StreamWatch` listens to every frame from the vehicle and notices it three ways: messages it had asked to
stop (or slow) arriving again, the share of the vehicle's frames lost by sequence number rising well above what the
link check measured, and another ground station's HEARTBEAT on the link (a router that passes frames between its
clients shows it). It then says what is happening and what to change on the ground station, and asks the streams
down again (the mission's own streams first), instead of letting the campaign run on a full link.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable
from typing import Any

from ksbo_mav.mav.linkcheck import LinkFigures
from ksbo_mav.mav.quieting import StreamQuieter, quiet_plan
from ksbo_mav.mav.stream_sets import group_of

#: Seconds after the last quieting command went out before a stopped message arriving counts: frames the vehicle
#: queued in a radio's buffer before it obeyed still come.
GRACE_S = 3.0
#: The watch's window (s): arrivals and sequence gaps are judged per window.
WINDOW_S = 2.0
#: Frames of stopped messages in one window that mean the streams were asked for again.
RETURNED_MIN = 3
#: Least time between two re-quietings for returned streams (s), and for loss alone (s).
REQUIET_GAP_S, LOSS_GAP_S = 5.0, 30.0
#: Loss in a window (share of the vehicle's frames, at least twice the link check's) that asks the streams down.
LOSS_MIN = 0.2
#: Seconds between two reports of the same thing on the console.
SAY_AGAIN_S = 60.0
MAV_TYPE_GCS = 6

GCS_ADVICE = ("MAVProxy: `set streamrate -1` and `set streamrate2 -1` (or start it with --streamrate -1); "
              "Mission Planner: lower Config > Planner > Telemetry Rates (it asks again whenever the rates it "
              "receives differ from them); QGroundControl: let the vehicle control the stream rates (Application "
              "Settings > MAVLink); or connect the ground station through a router that does not pass "
              "REQUEST_DATA_STREAM (message 66) to the vehicle; or, on ArduPilot, turn on the radio port's "
              "'Ignore Streamrate' option (MAVn_OPTIONS bit 2 from 4.7, SERIALn_OPTIONS bit 12 before; a reboot), "
              "which makes the vehicle ignore such requests")


def returned_line(names: list[str], others: str = "") -> str:
    """The console line for messages asked down that arrive again: who asked, and what to change there."""
    return (f"link: {', '.join(names[:6])}{' ...' if len(names) > 6 else ''} arrive again though asked "
            f"down{others}: a ground station on this link asked the vehicle for its streams again "
            "(REQUEST_DATA_STREAM), which fills the link; asked them down again. So that it stops asking: "
            f"{GCS_ADVICE}")


class StreamWatch:
    """Watches the vehicle's frames on ``quieter``'s link from construction until :meth:`stop`."""

    def __init__(self, quieter: StreamQuieter, needed: frozenset[str], lead: Callable[[], list[tuple[int, float]]],
                 log: Callable[[str], None], fig: LinkFigures, pace_hz: float) -> None:
        self.quieter, self.needed, self.lead, self.log = quieter, needed, lead, log
        self.pace_hz = pace_hz
        self.loss_at_check = fig.loss
        self.link = quieter.cmd.link
        self.asked_again = 0  # re-quietings because streams came back
        self.loss_requiets = 0  # re-quietings because frames were lost
        self.others: set[tuple[int, int]] = set()  # other ground stations heard on the link
        self._window_start = time.monotonic()
        self._counts: Counter[str] = Counter()
        self._early: Counter[str] = Counter()  # frames of stopped streams since the last re-quieting
        self._gaps = self._frames = 0
        self._last_seq: int | None = None
        self._last_requiet = self._last_loss_requiet = -1e9
        self._said: dict[str, float] = {}
        self.link.handlers.append(self._on_msg)

    def stop(self) -> None:
        if self._on_msg in self.link.handlers:
            self.link.handlers.remove(self._on_msg)

    def summary(self) -> dict[str, Any]:
        return {"streams_asked_again": self.asked_again, "requieted_for_loss": self.loss_requiets,
                "other_ground_stations": sorted(self.others)}

    def _on_msg(self, msg: Any) -> None:
        link = self.link
        if not link.is_vehicle(msg):
            src = (msg.get_srcSystem(), msg.get_srcComponent())
            if (msg.get_type() == "HEARTBEAT" and int(msg.type) == MAV_TYPE_GCS
                    and src != (link.mav.srcSystem, link.mav.srcComponent) and src not in self.others):
                self.others.add(src)
                self._say("other", f"link: another ground station (system {src[0]}, component {src[1]}) is on "
                          "this link; if it asks the vehicle for its streams, the link fills again")
            return
        seq = msg.get_seq()
        if self._last_seq is not None:
            self._gaps += (seq - self._last_seq - 1) % 256
        self._last_seq = seq
        self._frames += 1
        kind = msg.get_type()
        self._counts[kind] += 1
        now = time.monotonic()
        q = self.quieter
        if q.asked.get(kind) == 0 and not q.busy and now - q.last_sent >= GRACE_S:
            # a stopped stream is back: asked down at once, not at the window's end, for each of the mission's
            # samples lost meanwhile (the request also slowed the mission's own streams to their group's rate)
            self._early[kind] += 1
            if sum(self._early.values()) >= RETURNED_MIN and now - self._last_requiet >= REQUIET_GAP_S:
                self._returned(now, sorted(self._early))
        if now - self._window_start >= WINDOW_S:
            self._close_window(now)

    def _close_window(self, now: float) -> None:
        span = now - self._window_start
        counts, gaps, frames = self._counts, self._gaps, self._frames
        self._window_start, self._counts, self._gaps, self._frames = now, Counter(), 0, 0
        self._early.clear()
        q = self.quieter
        if q.busy or now - q.last_sent < GRACE_S:
            return  # still asking, or the frames queued before the vehicle obeyed are still arriving
        back = [n for n, hz in q.asked.items() if hz == 0 and counts[n]]
        faster = [n for n, hz in q.asked.items() if hz > 0 and counts[n] > max(RETURNED_MIN, 2.5 * hz * span)]
        returned = back + faster if faster or sum(counts[n] for n in back) >= RETURNED_MIN else []
        loss = gaps / max(gaps + frames, 1)
        if returned and now - self._last_requiet >= REQUIET_GAP_S:
            self._returned(now, returned)
        elif (frames >= 20 and loss > max(LOSS_MIN, 2 * self.loss_at_check)
              and now - self._last_loss_requiet >= LOSS_GAP_S):
            # The link is fuller than at the check. Streams already asked down are not the cause (the window would
            # show them back); what is worth asking is the table when nothing was asked yet (a ground station's
            # streams after a clean check), else only what else the vehicle now sends fast.
            self._last_loss_requiet = now
            fig = LinkFigures(seconds=span, bytes_per_s=0.0, rates_hz={k: n / span for k, n in counts.items()},
                              loss=loss)
            plan = quiet_plan(q.stack_name, self.needed, fig if q.asked else None)
            plan = {n: hz for n, hz in plan.items() if n not in q.asked and (not q.asked or counts[n])}
            if plan:
                self.loss_requiets += 1
                q.ask(plan, self.pace_hz, lead=self.lead())
                self._last_requiet = now
                self._say("loss", f"link: {loss:.0%} of the vehicle's frames lost by sequence number over the last "
                          f"{span:.0f} s ({self.loss_at_check:.0%} at the link check){self._others()}: asked the "
                          f"vehicle to stop or slow {len(plan)} more messages")

    def _returned(self, now: float, returned: list[str]) -> None:
        self.asked_again += 1
        self._early.clear()
        self._requiet(now, returned)
        if not self._say("returned", returned_line(returned, self._others())):
            self._say("returned-again", f"link: the streams were asked for again ({self.asked_again} times so "
                      "far); asked them down again each time")

    def _requiet(self, now: float, returned: list[str]) -> None:
        """Ask the returned messages down again, with the rest of their stream groups (a ground station's
        request resets whole groups, some of whose messages may not have shown yet), the campaign's own streams
        first."""
        q = self.quieter
        groups = {group_of(q.stack_name, n) for n in returned} - {None}
        plan = {n: q.asked[n] for n in returned} | {n: hz for n, hz in q.asked.items()
                                                    if group_of(q.stack_name, n) in groups}
        q.ask(plan, self.pace_hz, lead=self.lead())
        self._last_requiet = now

    def _others(self) -> str:
        if not self.others:
            return ""
        return " (another ground station is on this link: " + ", ".join(
            f"system {s} component {c}" for s, c in sorted(self.others)) + ")"

    def _say(self, key: str, text: str) -> bool:
        """Log ``text`` unless the same kind of report was logged less than :data:`SAY_AGAIN_S` ago."""
        now = time.monotonic()
        if now - self._said.get(key, -1e9) < SAY_AGAIN_S:
            return False
        self._said[key] = now
        self.log(text)
        return True
