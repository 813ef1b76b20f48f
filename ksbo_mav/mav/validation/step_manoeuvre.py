"""Position steps: single position targets (no velocity or acceleration feed-forward) in guided/offboard, each
offset flown out from the hover point and back, ``dwell_s`` on each; rise, overshoot and settling are measured by
:func:`ksbo_task.manoeuvre_metrics.step_response` from the markers (:mod:`.manoeuvre_recorder`)."""

from __future__ import annotations

import numpy as np

from ksbo_mav.mav.validation.manoeuvre_frame import ManoeuvreFrame
from ksbo_mav.mav.validation.manoeuvre_recorder import cfg_text, end_text, leg_text, start_text
from ksbo_mav.mav.validation.manoeuvre_spec import ManoeuvreSpec


def fly_steps(frame: ManoeuvreFrame, spec: ManoeuvreSpec, start: np.ndarray, label: str, detail: dict) -> None:
    """Fly the steps from a hover on ``start`` (NED); what it flew goes into ``detail``."""
    frame.hold_target(start, spec.settle_s)
    frame.marker(start_text(spec.kind, frame.now_ms(), label))
    frame.started = True
    frame.marker(cfg_text(spec.settle_fraction, spec.settle_floor_m, spec.settle_band_m, spec.arrive_m))
    targets = spec.step_targets(start)
    detail.update(start_ned=[float(v) for v in start], targets_ned=[[float(v) for v in t] for t in targets])
    g = frame.v.guided
    for target in targets:
        g.send(target)  # the new target goes out first: the leg marker names its time
        frame.marker(leg_text(frame.now_ms()))
        frame.hold_target(target, spec.dwell_s)
    frame.marker(end_text(frame.now_ms(), "ok"))
    frame.ended = True
