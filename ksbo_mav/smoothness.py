"""How smoothly a vehicle flew: what makes gains unflyable on a real airframe even while they track better.

Higher position and velocity gains turn sensor noise into attitude commands: the vehicle twitches, the motors
follow, a frame resonance may join in. A lap's tracking error cannot see that; its attitude can. From the ATTITUDE
samples of the scored lap (any stack streams them; the tool asks for them at the mission rate):

    rough   = RMS over the lap of |(p, q)_hp|   (deg/s)

with (p, q) the roll and pitch body rates resampled to a uniform grid and high-passed above ``cutoff_hz``
(a second-order Butterworth, run forwards and backwards: no phase lag). The figure-8's own manoeuvring lies far
below the cutoff (a lap of 10-20 s), what the loop adds on top of it above; ``tilt_max`` is the largest tilt of
the lap (deg). The rate needs at least 4 samples per cutoff period (Nyquist and a margin), else the lap's
roughness is not measured (None, with the reason).

The score's smoothness term (:meth:`ksbo_mav.mav.mission.Mission.score`, profile ``[score] smooth_weight``)
compares ``rough`` with the campaign baseline's, as the tracking term compares RMS errors:

    P = 1 - (rms / rms_ref + w max(0, rough - rough_ref) / max(rough_ref, FLOOR_DPS)) / ratio

so gains that track 20 % better but shake twice as much as the baseline (w = 0.5) lose more than they gain. The
floor keeps a baseline that barely moves (a simulator without sensor noise: 0.001 deg/s) from turning a
thousandth of a degree per second into a penalty.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: High-pass cutoff (Hz) of the body rates: above the figure-8's manoeuvring, below what telemetry carries.
CUTOFF_HZ = 2.0
#: Roughness (deg/s) below which a baseline counts as this smooth: what a real IMU's attitude telemetry carries
#: at rest, at the least.
FLOOR_DPS = 0.5
#: Samples per cutoff period the attitude stream must deliver for the roughness to be measured.
MIN_SAMPLES_PER_PERIOD = 4.0


def smoothness(t_s: np.ndarray, att: np.ndarray, cutoff_hz: float = CUTOFF_HZ) -> dict[str, Any]:
    """Roughness and tilt peak of one lap. ``t_s`` (n,) sample times (s, increasing), ``att`` (n, 4) rows of
    [roll, pitch, rollspeed, pitchspeed] (rad, rad/s) as ATTITUDE carries them. Returns ``rough_dps`` (None when
    the stream was too slow or too short, with ``rough_note``), ``tilt_max_deg`` and ``att_rate_hz``."""
    from scipy.signal import butter, sosfiltfilt

    t, a = np.asarray(t_s, dtype=float), np.asarray(att, dtype=float).reshape(-1, 4)
    keep = np.all(np.isfinite(a), axis=1) & np.isfinite(t)
    t, a = t[keep], a[keep]
    out: dict[str, Any] = {"rough_dps": None, "tilt_max_deg": None, "att_rate_hz": 0.0}
    if len(t) < 2 or t[-1] <= t[0]:
        return {**out, "rough_note": "fewer than two ATTITUDE samples in the scored lap"}
    span = float(t[-1] - t[0])
    rate = (len(t) - 1) / span
    tilt = np.degrees(np.arccos(np.clip(np.cos(a[:, 0]) * np.cos(a[:, 1]), -1.0, 1.0)))
    out.update(tilt_max_deg=float(tilt.max()), att_rate_hz=rate)
    if rate < MIN_SAMPLES_PER_PERIOD * cutoff_hz:
        return {**out, "rough_note": f"ATTITUDE at {rate:.1f} Hz: at least {MIN_SAMPLES_PER_PERIOD * cutoff_hz:g} Hz "
                                     f"measures the body rates above {cutoff_hz:g} Hz"}
    grid = np.arange(t[0], t[-1], 1.0 / rate)
    if len(grid) < 16 or span < 3.0 / cutoff_hz:
        return {**out, "rough_note": f"a lap of {span:.1f} s is too short to measure the body rates above "
                                     f"{cutoff_hz:g} Hz"}
    rates = np.stack([np.interp(grid, t, a[:, c]) for c in (2, 3)], axis=1)
    sos = butter(2, cutoff_hz, btype="highpass", fs=rate, output="sos")
    hp = sosfiltfilt(sos, rates, axis=0)
    out["rough_dps"] = float(np.degrees(np.sqrt(np.mean(np.sum(hp * hp, axis=1)))))
    return out


def smooth_penalty(rough: float | None, rough_ref: float | None, weight: float) -> float:
    """The smoothness term ``w max(0, rough - rough_ref) / max(rough_ref, FLOOR_DPS)`` (0 when either roughness is
    unknown)."""
    if weight <= 0 or rough is None or rough_ref is None or not np.isfinite(rough) or not np.isfinite(rough_ref):
        return 0.0
    return float(weight * max(0.0, rough - rough_ref) / max(rough_ref, FLOOR_DPS))
