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
