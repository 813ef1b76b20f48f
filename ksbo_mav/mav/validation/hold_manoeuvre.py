"""Position hold: from a hover on the start point in guided/offboard, the autopilot's own hold mode (ArduPilot
LOITER, PX4 Hold / AUTO.LOITER) for ``seconds``; the drift from the point where the hold began (the first position
sample once the mode is confirmed) is measured by :func:`ksbo_task.manoeuvre_metrics.hold_drift`.

ArduPilot's LOITER flies the pilot's sticks: it holds only with them centred, throttle included (off centre it
climbs, descends or moves). The sticks are read (RC_CHANNELS) before the switch and a hold with a stick outside its
dead zone is refused in one line; on a SITL bench the simulated transmitter's throttle rests low, so the bench must
centre it (its RC input port; docs/sitl.md). PX4's Hold needs no sticks.
"""

from __future__ import annotations

import numpy as np

from ksbo_mav.errors import PreflightError
from ksbo_mav.mav.wire import mavlink
from ksbo_mav.mav.validation.manoeuvre_frame import ManoeuvreFrame
from ksbo_mav.mav.validation.manoeuvre_recorder import cfg_text, end_text, hold_text, start_text
from ksbo_mav.mav.validation.manoeuvre_spec import ManoeuvreSpec


def fly_hold(frame: ManoeuvreFrame, spec: ManoeuvreSpec, start: np.ndarray, label: str, detail: dict) -> None:
    """Hold for ``spec.seconds`` in the hold mode, then back to guided on ``start``; what it flew goes into
    ``detail``."""
    detail.update(start_ned=[float(v) for v in start], mode=frame.v.stack.mode_name(frame.v.stack.modes["hold"]))
    frame.hold_target(start, spec.settle_s)
    frame.marker(start_text(spec.kind, frame.now_ms(), label))
    frame.started = True
    frame.marker(cfg_text(spec.settle_fraction, spec.settle_floor_m, spec.settle_band_m, spec.arrive_m))
    if frame.v.stack.name == "ardupilot":
        check_sticks_centred(frame)
    t_hold = frame.enter("hold")
    frame.marker(hold_text(t_hold))
    frame.watch(spec.seconds, "hold")
    frame.marker(end_text(frame.now_ms(), "ok"))
    frame.ended = True
    frame.back_to_guided()
    frame.hold_target(start, spec.settle_s)


def check_sticks_centred(frame: ManoeuvreFrame) -> None:
    """:class:`PreflightError` unless ArduPilot's RC inputs 1-4 sit in their dead zones: roll, pitch and yaw within
    ``RCn_DZ`` of ``RCn_TRIM``, the throttle within ``THR_DZ`` of mid-stick (LOITER's climb rate is zero there)."""
    v = frame.v
    msg = v.cmd.request_message(mavlink.MAVLINK_MSG_ID_RC_CHANNELS, "RC_CHANNELS")
    if msg is None or not msg.chancount or not msg.chan3_raw:
        raise PreflightError("LOITER follows the pilot's sticks and the vehicle reports no RC input: fly the hold "
                             "with a transmitter connected and its sticks centred")
    table = v.params.table

    def p(name: str, default: float) -> float:
        return float(table[name].value) if name in table else default

    lo, hi = p("RC3_MIN", 1000), p("RC3_MAX", 2000)
    wanted = {1: (p("RC1_TRIM", 1500), p("RC1_DZ", 20)), 2: (p("RC2_TRIM", 1500), p("RC2_DZ", 20)),
              3: ((lo + hi) / 2, p("THR_DZ", 100) * (hi - lo) / 1000), 4: (p("RC4_TRIM", 1500), p("RC4_DZ", 20))}
    names = {1: "roll", 2: "pitch", 3: "throttle", 4: "yaw"}
    for ch, (centre, dz) in wanted.items():
        raw = int(getattr(msg, f"chan{ch}_raw"))
        if abs(raw - centre) > dz:
            raise PreflightError(f"the {names[ch]} stick is at {raw} us, {centre:g} +/- {dz:g} us is centred: LOITER "
                                 "would move the vehicle; centre the sticks for the hold")
