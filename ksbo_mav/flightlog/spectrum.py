"""The tracking error's spectrum over a segment: an oscillating loop shows as a peak at its frequency.

The error against the autopilot's target is resampled on a uniform grid at the target's own rate, each axis
detrended and Hann-windowed, and its one-sided amplitude spectrum taken (m per bin: a sinusoidal error of
amplitude A shows as a peak of about A). The peak is searched above two cycles per segment.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ksbo_mav.flightlog.model import FlightLog


def error_spectrum(log: FlightLog, t0: float, t1: float) -> dict[str, Any] | None:
    """``{fs_hz, freq_hz, amp_h_m, amp_v_m, peak_hz, peak_amp_m, peak_v_hz, peak_v_amp_m}`` or None when the
    segment holds too few target samples."""
    tg = log.target.window(t0, t1)
    if len(tg) < 32:
        return None
    fs = 1.0 / float(np.median(np.diff(tg.t)))
    t = np.arange(tg.t[0], tg.t[-1], 1.0 / fs)
    err = log.actual.at(t) - log.target.at(t)
    ok = np.all(np.isfinite(err), axis=1)
    if ok.sum() < 32:
        return None
    for k in range(3):  # fill gaps by interpolation so that the grid stays uniform
        err[~ok, k] = np.interp(t[~ok], t[ok], err[ok, k])
    n = len(t)
    w = np.hanning(n)
    x = np.arange(n)
    amp = []
    for k in range(3):
        e = err[:, k] - np.polyval(np.polyfit(x, err[:, k], 1), x)
        amp.append(2.0 * np.abs(np.fft.rfft(e * w)) / w.sum())
    freq = np.fft.rfftfreq(n, 1.0 / fs)
    amp_h = np.hypot(amp[0], amp[1])
    amp_v = amp[2]
    band = freq >= 2.0 / (t[-1] - t[0])
    if not band.any():
        return None
    ih = int(np.flatnonzero(band)[np.argmax(amp_h[band])])
    iv = int(np.flatnonzero(band)[np.argmax(amp_v[band])])
    return {"fs_hz": fs, "freq_hz": freq, "amp_h_m": amp_h, "amp_v_m": amp_v,
            "peak_hz": float(freq[ih]), "peak_amp_m": float(amp_h[ih]),
            "peak_v_hz": float(freq[iv]), "peak_v_amp_m": float(amp_v[iv])}


def summary(spec: dict[str, Any] | None) -> dict[str, Any] | None:
    """The JSON-friendly part (peaks, not the arrays)."""
    if spec is None:
        return None
    return {k: v for k, v in spec.items() if not isinstance(v, np.ndarray)}
