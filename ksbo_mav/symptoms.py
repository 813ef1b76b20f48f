"""What a flight shows beyond its score: symptoms an engineer reads off the telemetry.

* ``pitch_chatter`` — rms of the step-to-step change of the pitch rate over its rms, in the scored lap. A smooth
  rate gives about 0; white noise √2; a rate that flips sign every control step (the limit cycle a derivative gain
  too high for the loop's sample rate drives) up to 2. Measured from a0 on the planar plants (issue 13 item AL):
  1.37 at a0's pitch D gain on nominal and pitch inertia ×0.5, 0.03 once the D gain is low enough.
"""

from __future__ import annotations

import numpy as np


def chatter_ratio(rate: np.ndarray) -> float:
    """rms(diff(rate)) / rms(rate) of a (n,) rate signal (NaN samples dropped); NaN if too short or all zero."""
    r = np.asarray(rate, dtype=float)
    r = r[np.isfinite(r)]
    if r.size < 3:
        return float("nan")
    total = float(np.sqrt(np.mean(r**2)))
    return float(np.sqrt(np.mean(np.diff(r) ** 2)) / total) if total > 0 else float("nan")


def trajectory_symptoms(kind: str, traj, window: tuple[int, int]) -> dict[str, float] | None:
    """Symptoms of a flown trajectory (``ksbo_mav.objective.Trajectory``) of a ``kind`` mission: the planar
    figure-8's ``pitch_chatter`` over the scored ``window`` of control steps (complete flights: the same samples as
    the in-process episode's); None for other missions or when the window holds no rate."""
    if kind != "figure8-xz" or traj.states.size == 0:
        return None
    lo, hi = window
    inside = (np.asarray(traj.steps) >= lo) & (np.asarray(traj.steps) < hi)
    ratio = chatter_ratio(np.asarray(traj.states)[inside, 5])
    return {"pitch_chatter": ratio} if np.isfinite(ratio) else None
