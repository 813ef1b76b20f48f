"""What a flight shows beyond its score: symptoms an engineer reads off the telemetry.

* ``pitch_chatter`` — rms of the step-to-step change of the pitch rate over its rms, in the scored lap. A smooth
  rate gives about 0; white noise √2; a rate that flips sign every control step (the limit cycle a derivative gain
  too high for the loop's sample rate drives) up to 2. Measured from a0 on the planar plants (issue 13 item AL):
  1.37 at a0's pitch D gain on nominal and pitch inertia ×0.5, 0.03 once the D gain is low enough. Sensor noise
  raises it too (1.0–1.2 at every D gain on the 3× noise plant), so it cannot tell noise from a limit cycle.
* ``pitch_line`` — the fraction of the pitch rate's power in its strongest narrow spectral line above 0.1 cycles
  per sample (5 Hz at the 50 Hz control rate): a limit cycle is a line, noise is spread. Along the pitch D gain
  from a0 on the planar plants (issue 13 item AM, the 8 fixed starts): 0.89–0.99 where the rate cycles (nominal,
  pitch inertia ×0.5, mass +30 % and motor lag at a0's D gain), 0.58–0.83 on gusts, 0.08–0.28 on the 3× noise
  plant at every D gain, 0.00–0.10 without a cycle.
"""

from __future__ import annotations

import numpy as np

#: The symptoms :func:`rate_symptoms` reports.
SYMPTOMS = ("pitch_line", "pitch_chatter")


def chatter_ratio(rate: np.ndarray) -> float:
    """rms(diff(rate)) / rms(rate) of a (n,) rate signal (NaN samples dropped); NaN if too short or all zero."""
    r = np.asarray(rate, dtype=float)
    r = r[np.isfinite(r)]
    if r.size < 3:
        return float("nan")
    total = float(np.sqrt(np.mean(r**2)))
    return float(np.sqrt(np.mean(np.diff(r) ** 2)) / total) if total > 0 else float("nan")


#: Lowest frequency (cycles per sample) of :func:`line_fraction`'s line: above the figure-8's manoeuvres.
LINE_MIN_FREQ = 0.1
#: Half width (bins) of the line: the Hann window's main lobe.
LINE_HALF_WIDTH = 3
#: Fewest samples :func:`line_fraction` reads a spectrum from.
LINE_MIN_SAMPLES = 32


def line_fraction(rate: np.ndarray) -> float:
    """Fraction of a (n,) uniformly sampled rate's power (mean removed, Hann window) in the strongest spectral line
    above :data:`LINE_MIN_FREQ` cycles per sample (± :data:`LINE_HALF_WIDTH` bins); NaN samples dropped, NaN if
    fewer than :data:`LINE_MIN_SAMPLES` remain or the rate is constant."""
    r = np.asarray(rate, dtype=float)
    r = r[np.isfinite(r)]
    if r.size < LINE_MIN_SAMPLES:
        return float("nan")
    power = np.abs(np.fft.rfft((r - r.mean()) * np.hanning(r.size))) ** 2
    total = float(power.sum())
    if not total > 0:
        return float("nan")
    high = np.flatnonzero(np.fft.rfftfreq(r.size) >= LINE_MIN_FREQ)
    k = int(high[np.argmax(power[high])])
    return float(power[max(k - LINE_HALF_WIDTH, 0) : k + LINE_HALF_WIDTH + 1].sum() / total)


def rate_symptoms(pitch_rate: np.ndarray) -> dict[str, float]:
    """The symptoms of a (n,) pitch rate sampled at the control rate over the scored lap (finite ones only)."""
    found = {"pitch_chatter": chatter_ratio(pitch_rate), "pitch_line": line_fraction(pitch_rate)}
    return {k: v for k, v in found.items() if np.isfinite(v)}


def trajectory_symptoms(kind: str, traj, window: tuple[int, int]) -> dict[str, float] | None:
    """Symptoms of a flown trajectory (``ksbo_mav.objective.Trajectory``) of a ``kind`` mission: the planar
    figure-8's :func:`rate_symptoms` over the scored ``window`` of control steps (complete flights: the same samples
    as the in-process episode's); None for other missions or when the window holds no rate."""
    if kind != "figure8-xz" or traj.states.size == 0:
        return None
    lo, hi = window
    steps = np.asarray(traj.steps)
    inside = (steps >= lo) & (steps < hi) & np.isfinite(np.asarray(traj.states)[:, 5])
    if inside.sum() < 3:
        return None
    k, rate = steps[inside], np.asarray(traj.states)[inside, 5]
    grid = np.arange(k.min(), k.max() + 1)
    if grid.size != k.size:  # telemetry lost a few samples: the spectrum needs the control-rate grid
        rate = np.interp(grid, k, rate)
    return rate_symptoms(rate) or None
