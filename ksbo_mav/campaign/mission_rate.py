"""The mission rate a campaign flies at, set on the vehicle here and only here: the rate
:func:`ksbo_mav.campaign.config.settle` decided, then the link check: before the baseline is read or anything is
armed, measure what the link delivers at the mission's stream rates (:mod:`ksbo_mav.mav.linkcheck` does the
measuring), step a rate nobody asked for down when the link cannot carry it, refuse in one line when a trial could
not be flown over it, and keep the figures in the campaign directory (``link.json``, one entry per start or
resume) for the report."""

from __future__ import annotations

import json
import time
from collections.abc import Callable

from ksbo_mav.campaign.config import MissionRate
from ksbo_mav.campaign.layout import CampaignDir, write_file
from ksbo_mav.campaign.settings import MISSION_RATES_HZ
from ksbo_mav.errors import PreflightError, VehicleError
from ksbo_mav.mav.linkcheck import (UPLINK_MIN_FREE, LinkFigures, judged, judged_stream, measure, needed_streams,
                                    probe_uplink, verdict)
from ksbo_mav.mav.quieting import arrives_above, describe_asked, pace_for, quiet_plan
from ksbo_mav.mav.stream_watch import GRACE_S, StreamWatch, returned_line
from ksbo_mav.mav.vehicle import Vehicle


#: Mission rates (Hz) a campaign may step down to when the link cannot carry the profile's: setpoints carry
#: velocity and acceleration feed-forward, so the autopilot's controller fills in between them (docs/links.md).
REDUCED_RATES_HZ = MISSION_RATES_HZ[1:]
#: A lower rate is taken only when it also arrives nearly whole: more frames lost at it mean the link is full. A
#: radio loses a few per cent on the air at any rate (the tool's writes are verified up to 10 % loss), so up to 10 %.
MAX_LOSS_REDUCED = 0.10
#: A lower rate is taken only when it also leaves a quarter of what the link carried when full: the rest of a
#: campaign (gain writes, the onboard guard's upload, a ground station's burst) needs room on the same radio. At
#: 96 % of a 2 kB/s half-duplex radio the guard's report was lost (ArduCopter SITL, the emulator's sik case).
HEADROOM = 0.75
#: Bytes of one SET_POSITION_TARGET_LOCAL_NED on the wire (MAVLink 2, 53-byte payload + 12).
FRAME_BYTES = 65
#: Seconds to wait for the position estimate before the link is measured (GPS lock and EKF origin on the ground).
POSITION_WAIT_S = 90.0
#: Rounds of asking the vehicle's streams down while the link loses frames: (a message the stack's table does not
#: list is asked down when the vehicle sends it faster than this, Hz; to this rate, Hz; the ground station's picture
#: at its rate times this). The table's messages are stopped in every round, whether or not they arrived; the
#: second round catches streams the first made room for, the third slows the picture and the rest to once every
#: five seconds. A round never raises a rate an earlier one asked.
QUIET_ROUNDS = ((1.1, 1.0, 1.0), (1.1, 1.0, 1.0), (0.3, 0.2, 0.2))
#: Rounds repeated, per rate, because streams already measured quiet came back: a ground station on the link asked
#: for them again (MAVProxy does every 15 s), which says nothing about what the link carries once they are down.
REFILL_ROUNDS = 3


def _judge(v: Vehicle, seconds: float) -> tuple[LinkFigures, str | None]:
    try:
        v.setup_streams()
    except VehicleError:
        # a full downlink drops the acknowledgement of a rate request that went up and may have taken effect:
        # what arrives next says whether it did, and the verdict names the link rather than a missing ACK
        pass
    fig = measure(v.link, seconds)
    why = verdict(fig, float(v.mission.rate_hz))
    if why:  # once more: a burst (the vehicle's parameter download, a ground station joining) may have passed
        fig = measure(v.link, 2 * seconds)
        why = verdict(fig, float(v.mission.rate_hz))
    v.streams.note_quiet(fig)
    if why is None and fig.radio is not None and not v.lockstep:
        why = _uplink_verdict(v, seconds)
    return fig, why


def _uplink_verdict(v: Vehicle, seconds: float) -> str | None:
    """With a radio that reports its buffer: None when it carries the mission's setpoints, else why not."""
    rate = v.mission.rate_hz
    free = probe_uplink(v.link, rate, seconds)
    if free is None or free >= UPLINK_MIN_FREE:
        return None
    return (f"link check: setpoints at {rate} Hz (about {rate * FRAME_BYTES / 1000:.1f} kB/s up) fill the ground "
            f"radio's buffer (down to {free} % free): use a faster radio air rate, or fly a profile with a lower "
            "mission rate (docs/links.md); nothing was written to the vehicle")


def fly_at(v: Vehicle, rate: MissionRate, log: Callable[[str], None]) -> LinkFigures:
    """Set the mission to ``rate`` and check the link carries it (:func:`check_link`; a lowerable rate is stepped
    down to what it carries)."""
    v.set_mission_rate(rate.hz)
    return check_link(v, log, reduce=rate.lowerable)


def check_link(v: Vehicle, log: Callable[[str], None], seconds: float = 3.0, reduce: bool = True) -> LinkFigures:
    """:func:`judge_link`, then the command waits and attempts sized to the round trip and loss it measured."""
    fig = judge_link(v, log, seconds, reduce)
    sized = v.cmd.size_for_link(fig.rtt_ms, fig.loss)
    if sized:
        log(sized)
    watch_streams(v, fig, log)
    return fig


def watch_streams(v: Vehicle, fig: LinkFigures, log: Callable[[str], None]) -> None:
    """From now until the vehicle is closed: notice a ground station on the link asking for its streams again
    (:class:`~ksbo_mav.mav.stream_watch.StreamWatch`), say so and ask them down again."""
    if v.stream_watch is not None:
        v.stream_watch.stop()
    v.stream_watch = StreamWatch(v.streams, needed_streams(v.mission.kind), v.telemetry.mission_intervals, log,
                                 fig, pace_for(fig))


def await_position(v: Vehicle, log: Callable[[str], None], timeout_s: float = POSITION_WAIT_S) -> None:
    """Wait (up to ``timeout_s``) for the vehicle's LOCAL_POSITION_NED: on the ground before GPS an autopilot
    streams ATTITUDE only, and a link that carries that alone may not carry the position stream beside it; the
    link is judged once both stream. A lockstep simulator's clock is paused on the ground: nothing to wait for."""
    if v.lockstep:
        return
    try:
        v.setup_streams()
    except VehicleError:
        pass  # as in _judge: what arrives says whether the request took effect
    def is_position(m: object) -> bool:
        return m.get_type() == "LOCAL_POSITION_NED" and v.link.is_vehicle(m)  # type: ignore[attr-defined]

    if v.link.wait(is_position, 1.0) is not None:
        return
    log(f"link: waiting up to {timeout_s:g} s for the position estimate (LOCAL_POSITION_NED) before measuring")
    if v.link.wait(is_position, timeout_s) is None:
        log("link: still no position estimate; the link is judged on ATTITUDE, which the position stream will join")


def judge_link(v: Vehicle, log: Callable[[str], None], seconds: float = 3.0, reduce: bool = True) -> LinkFigures:
    """Request the mission's streams, measure the link for ``seconds``, say what it delivers. When a trial could
    not be flown over it at the mission's rate and ``reduce``, step the rate (setpoints and telemetry) down through
    :data:`REDUCED_RATES_HZ` to the first the link carries with at most :data:`MAX_LOSS_REDUCED` of the frames lost,
    and say so; PreflightError (one line naming the measured and needed rates) when none fits."""
    asked = v.mission.rate_hz
    await_position(v, log)
    fig, why = _judge(v, seconds)
    log(f"link: {fig.describe()}" + (f" (the mission needs {judged_stream(fig)} at {asked} Hz)"
                                     if judged(fig) else ""))
    if v.streams.asked:  # asked down while connecting
        log(_confirmed(fig))
    fig, why = _make_room(v, fig, why, seconds, log)
    if why and reduce:
        log(why.split("; nothing was written")[0].split(": use ")[0] + ": trying lower mission rates")
        full = fig.bytes_per_s  # what the link carries when full: a rate kept leaves room below it
        tight: tuple[int, LinkFigures] | None = None  # the lowest rate carried without that room
        for rate in (r for r in REDUCED_RATES_HZ if r < asked):
            v.set_mission_rate(rate)
            fig2, why2 = _judge(v, 2 * seconds)  # a longer look: a rate kept must hold, not just pass once
            log(f"link: at {rate} Hz: {fig2.describe()}")
            fig2, why2 = _make_room(v, fig2, why2, seconds, log)  # what a lower rate leaves may show more
            if fig2.loss > MAX_LOSS_REDUCED:
                full = max(full, fig2.bytes_per_s)
            if why2 is None and fig2.loss <= MAX_LOSS_REDUCED and fig2.bytes_per_s > HEADROOM * full:
                log(f"link: at {rate} Hz the link is {fig2.bytes_per_s / full:.0%} full ({fig2.bytes_per_s / 1000:.2f} "
                    f"of the {full / 1000:.2f} kB/s it carried when full): leaving room for commands, parameter "
                    "writes and bursts")
                tight = (rate, fig2)
                continue
            if why2 is None and fig2.loss <= MAX_LOSS_REDUCED:
                return _fly_at(v, rate, asked, fig2, log, "")
        if tight is not None:  # no rate left room: the lowest that carried the link, said as tight
            v.set_mission_rate(tight[0])
            return _fly_at(v, tight[0], asked, tight[1], log, "; the link stays nearly full: commands may need "
                           "their retries")
        v.set_mission_rate(asked)
        why += f" (tried {', '.join(str(r) for r in REDUCED_RATES_HZ if r < asked)} Hz too)"
    if why:
        raise PreflightError(why)
    return fig


def _fly_at(v: Vehicle, rate: int, asked: int, fig: LinkFigures, log: Callable[[str], None],
            note: str) -> LinkFigures:
    log(f"link: flying at {rate} Hz instead of {asked} Hz (setpoints with velocity and acceleration "
        f"feed-forward, telemetry at {rate} Hz): the link carries it ({fig.describe()}){note}")
    fig.reduced_from_hz = asked
    return fig


def _make_room(v: Vehicle, fig: LinkFigures, why: str | None, seconds: float,
               log: Callable[[str], None]) -> tuple[LinkFigures, str | None]:
    """While the link is full (a verdict against it, or more than :data:`MAX_LOSS_REDUCED` of the vehicle's frames
    lost), ask the vehicle's streams the campaign does not use down by :data:`QUIET_ROUNDS`: every message of the
    stack's default stream sets (:mod:`ksbo_mav.mav.stream_sets`), whether or not it arrived, and whatever else it
    sends fast by its sequence numbers; then measure again and say whether the vehicle now sends what the link
    carries. Returns the last figures."""
    needed = needed_streams(v.mission.kind)
    v.streams.log = log
    rounds, refills = list(QUIET_ROUNDS), 0
    while rounds:
        above_hz, to_hz, scale = rounds.pop(0)
        if not (why or fig.loss > MAX_LOSS_REDUCED):
            break
        asked = dict(v.streams.asked)
        plan = {n: min(hz, asked.get(n, hz)) for n, hz in
                quiet_plan(v.stack.name, needed, fig, above_hz, to_hz, scale).items()}
        changed = {n: hz for n, hz in plan.items() if asked.get(n) != hz}
        # Asked before, yet arriving: a command lost on the way up (a full radio drops them too), or not obeyed; or,
        # when they had been quiet, asked for again by a ground station on the link.
        back = [n for n, hz in plan.items() if n not in changed and arrives_above(fig, n, hz)]
        returned = [n for n in back if n in v.streams.quiet_seen]
        if not changed and not back:
            continue
        first = {n: plan[n] for n in back} | changed
        v.streams.ask(first | plan if back else first, pace_for(fig), lead=v.telemetry.mission_intervals())
        v.streams.flush()
        if changed:
            log(describe_asked(v.stack.name, fig, changed))
        if returned:
            if not v.streams.gcs_said:
                log(returned_line(returned))
                v.streams.gcs_said = True
            if refills < REFILL_ROUNDS:  # this round again: the streams came back, not the link filled up
                refills += 1
                rounds.insert(0, (above_hz, to_hz, scale))
        elif back:
            log(f"link: {', '.join(back[:8])}{' ...' if len(back) > 8 else ''} still arrive though asked down "
                f"(a command lost on the way up?): asked the vehicle again for all {len(plan)}")
        # frames the vehicle queued in the radio's buffer before it obeyed still arrive, and their gaps with them
        v.link.wait(lambda m: False, GRACE_S)
        fig, why = _judge(v, 2 * seconds)
        log(f"link: {fig.describe()}")
        log(_confirmed(fig))
    return fig, why


def _confirmed(fig: LinkFigures) -> str:
    """Whether the vehicle now sends what the link carries, by its sequence numbers."""
    sent, got = fig.sent_bytes_per_s / 1000, fig.bytes_per_s / 1000
    if fig.loss <= MAX_LOSS_REDUCED:
        return (f"link: by its sequence numbers the vehicle now sends about {sent:.1f} kB/s and {got:.1f} arrive "
                f"({fig.loss:.0%} lost): the link carries what the vehicle sends")
    return (f"link: by its sequence numbers the vehicle still sends about {sent:.1f} kB/s and {got:.1f} arrive "
            f"({fig.loss:.0%} lost)")


def record_link(d: CampaignDir, fig: LinkFigures, on_link_loss: str | None = None) -> None:
    """Append the figures to ``link.json`` (a list: the campaign's start and each resume), with what the vehicle
    does if the link dies mid-trial (``on_link_loss``, PX4: :mod:`ksbo_mav.campaign.link_loss_policy`)."""
    path = d.link
    try:
        old = json.loads(path.read_text()) if path.is_file() else []
    except (OSError, ValueError):
        old = []
    record = {"at": time.strftime("%Y-%m-%dT%H:%M:%S"), **fig.to_dict(),
              **({"on_link_loss": on_link_loss} if on_link_loss else {})}
    write_file(path, json.dumps([*old, record], indent=1))
