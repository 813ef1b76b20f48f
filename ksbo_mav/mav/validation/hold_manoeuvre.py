"""Position hold: from a hover on the start point in guided/offboard, the autopilot's own hold mode (ArduPilot
LOITER, PX4 Hold / AUTO.LOITER) for ``seconds``; the drift from the point where the hold began (the first position
sample once the mode is confirmed) is measured by :func:`ksbo_task.manoeuvre_metrics.hold_drift`.

ArduPilot's LOITER flies the pilot's sticks: with the transmitter centred (or, on a SITL, its simulated RC at
mid-stick) it holds. PX4's Hold needs no sticks.
"""

from __future__ import annotations

import numpy as np

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
    t_hold = frame.enter("hold")
    frame.marker(hold_text(t_hold))
    frame.watch(spec.seconds, "hold")
    frame.marker(end_text(frame.now_ms(), "ok"))
    frame.ended = True
    frame.back_to_guided()
    frame.hold_target(start, spec.settle_s)
