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
                                    probe_uplink, quiet_other_streams, verdict)
from ksbo_mav.mav.vehicle import Vehicle


#: Mission rates (Hz) a campaign may step down to when the link cannot carry the profile's: setpoints carry
#: velocity and acceleration feed-forward, so the autopilot's controller fills in between them (docs/links.md).
REDUCED_RATES_HZ = MISSION_RATES_HZ[1:]
#: A lower rate is taken only when it also arrives nearly whole: more frames lost at it mean the link is full. A
#: radio loses a few per cent on the air at any rate (the tool's writes are verified up to 10 % loss), so up to 10 %.
MAX_LOSS_REDUCED = 0.10
#: Bytes of one SET_POSITION_TARGET_LOCAL_NED on the wire (MAVLink 2, 53-byte payload + 12).
FRAME_BYTES = 65
#: Seconds to wait for the position estimate before the link is measured (GPS lock and EKF origin on the ground).
POSITION_WAIT_S = 90.0
#: Rounds of quieting the streams the campaign does not use, while the link loses frames: (streams the vehicle
#: sends faster than this, Hz; are asked for this rate, Hz). Twice once a second (streams the first round made room
#: for arrive faster after it), then once every five seconds when the link is still full.
QUIET_ROUNDS = ((1.1, 1.0), (1.1, 1.0), (0.3, 0.2))


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
    return fig


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
    fig, why = _make_room(v, fig, why, seconds, log)
    if why and reduce:
        log(why.split("; nothing was written")[0].split(": use ")[0] + ": trying lower mission rates")
        for rate in (r for r in REDUCED_RATES_HZ if r < asked):
            v.set_mission_rate(rate)
            fig2, why2 = _judge(v, 2 * seconds)  # a longer look: a rate kept must hold, not just pass once
            log(f"link: at {rate} Hz: {fig2.describe()}")
            fig2, why2 = _make_room(v, fig2, why2, seconds, log)  # what a lower rate leaves may show more
            if why2 is None and fig2.loss <= MAX_LOSS_REDUCED:
                log(f"link: flying at {rate} Hz instead of {asked} Hz (setpoints with velocity and acceleration "
                    f"feed-forward, telemetry at {rate} Hz): the link carries it ({fig2.describe()})")
                fig2.reduced_from_hz = asked
                return fig2
        v.set_mission_rate(asked)
        why += f" (tried {', '.join(str(r) for r in REDUCED_RATES_HZ if r < asked)} Hz too)"
    if why:
        raise PreflightError(why)
    return fig


def _make_room(v: Vehicle, fig: LinkFigures, why: str | None, seconds: float,
               log: Callable[[str], None]) -> tuple[LinkFigures, str | None]:
    """While the link is full (a verdict against it, or more than :data:`MAX_LOSS_REDUCED` of the vehicle's frames
    lost), quiet the streams the campaign does not use by :data:`QUIET_ROUNDS`, judged by what the vehicle sends
    (its sequence numbers), not by what of it happened to arrive, and measure again; the last figures."""
    for above_hz, to_hz in QUIET_ROUNDS:
        if not (why or fig.loss > MAX_LOSS_REDUCED):
            break
        quieted = quiet_other_streams(v.cmd, fig, above_hz, to_hz, needed_streams(v.mission.kind))
        if not quieted:
            continue
        every = "once a second" if to_hz == 1.0 else f"once every {1 / to_hz:g} s"
        log(f"link: the vehicle sends about {fig.sent_bytes_per_s / 1000:.1f} kB/s, {fig.bytes_per_s / 1000:.1f} "
            f"arrive ({fig.loss:.0%} of its frames lost by sequence number): asked it to send {', '.join(quieted)} "
            f"{every} on this link (not used by the campaign; no parameter changed, a reboot restores them)")
        fig, why = _judge(v, 2 * seconds)
        log(f"link: {fig.describe()}")
    return fig, why


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
