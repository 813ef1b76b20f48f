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

    P = 1 - (rms / rms_ref + w max(0, rough - rough_ref - b r) / r) / ratio,   r = max(rough_ref, FLOOR_DPS)

so gains that track 20 % better but shake twice as much as the baseline (w = 0.5) lose more than they gain. The
floor keeps a baseline that barely moves (a simulator without sensor noise: 0.001 deg/s) from turning a
thousandth of a degree per second into a penalty; below about 1 deg/s roughness says how the setpoints arrive
rather than what the gains do (the same gains on ArduCopter SITL in turbulent wind: 1.3-1.5 deg/s with the
figure-8 streamed at 50 Hz, 0.45-0.7 deg/s flown on board). The band b (profile ``[score] rough_band``, a
fraction of r) is the roughness measure's own scatter: the same gains flown twice differed by up to 16 % in
roughness (ArduCopter SITL in turbulent wind, benchmarks/notes/smooth-gains.md), and a term charging that much
would score the flight, not the gains.

What the motors do is measured too where the vehicle streams SERVO_OUTPUT_RAW fast enough (what a flight
controller engineer reads from RCOU): the motor oscillation, recorded beside the roughness, not scored,

    motor_osc = RMS over the lap and the motors of pwm_hp   (µs)

with pwm the outputs of the motors (the channels carrying a PWM value, 800-2200 µs, through the lap) high-passed
as the body rates are. ArduCopter streams it in its RC_CHAN group, PX4 in its Normal mode, our simulators always;
at a rate below 4 per cutoff period it is not measured (``motor_note`` says why).
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: High-pass cutoff (Hz) of the body rates: above the figure-8's manoeuvring, below what telemetry carries.
CUTOFF_HZ = 2.0
#: Roughness (deg/s) below which a baseline counts as this smooth: below it the figure reflects how the setpoints
#: reach the vehicle more than what its gains do (module docstring).
FLOOR_DPS = 1.0
#: Samples per cutoff period the attitude stream must deliver for the roughness to be measured.
MIN_SAMPLES_PER_PERIOD = 4.0


def smoothness(t_s: np.ndarray, att: np.ndarray, cutoff_hz: float = CUTOFF_HZ) -> dict[str, Any]:
    """Roughness and tilt peak of one lap. ``t_s`` (n,) sample times (s, increasing), ``att`` (n, 4) rows of
    [roll, pitch, rollspeed, pitchspeed] (rad, rad/s) as ATTITUDE carries them. Returns ``rough_dps`` (None when
    the stream was too slow or too short, with ``rough_note``), ``tilt_max_deg`` and ``att_rate_hz``."""
    t, a = np.asarray(t_s, dtype=float), np.asarray(att, dtype=float).reshape(-1, 4)
    keep = np.all(np.isfinite(a), axis=1) & np.isfinite(t)
    t, a = t[keep], a[keep]
    out: dict[str, Any] = {"rough_dps": None, "tilt_max_deg": None, "att_rate_hz": 0.0}
    if len(t) >= 2:
        tilt = np.degrees(np.arccos(np.clip(np.cos(a[:, 0]) * np.cos(a[:, 1]), -1.0, 1.0)))
        out["tilt_max_deg"] = float(tilt.max())
    rough, rate, why = _highpass_rms(t, a[:, 2:4], cutoff_hz, "ATTITUDE")
    out["att_rate_hz"] = rate
    if rough is None:
        return {**out, "rough_note": why}
    out["rough_dps"] = float(np.degrees(rough))
    return out


def _highpass_rms(t: np.ndarray, cols: np.ndarray, cutoff_hz: float, what: str) -> tuple[float | None, float, str]:
    """(RMS of ``cols`` (n, k) high-passed above ``cutoff_hz``, summed over the k columns, or None; the sample
    rate (Hz); why it was not measured) for samples at times ``t`` (n,) s, increasing."""
    from scipy.signal import butter, sosfiltfilt

    if len(t) < 2 or t[-1] <= t[0]:
        return None, 0.0, f"fewer than two {what} samples in the scored lap"
    span = float(t[-1] - t[0])
    rate = (len(t) - 1) / span
    if rate < MIN_SAMPLES_PER_PERIOD * cutoff_hz:
        return None, rate, (f"{what} at {rate:.1f} Hz: at least {MIN_SAMPLES_PER_PERIOD * cutoff_hz:g} Hz measures "
                            f"what lies above {cutoff_hz:g} Hz")
    grid = np.arange(t[0], t[-1], 1.0 / rate)
    if len(grid) < 16 or span < 3.0 / cutoff_hz:
        return None, rate, f"a lap of {span:.1f} s is too short to measure what lies above {cutoff_hz:g} Hz"
    resampled = np.stack([np.interp(grid, t, cols[:, c]) for c in range(cols.shape[1])], axis=1)
    hp = sosfiltfilt(butter(2, cutoff_hz, btype="highpass", fs=rate, output="sos"), resampled, axis=0)
    return float(np.sqrt(np.mean(np.sum(hp * hp, axis=1)))), rate, ""


#: A channel of SERVO_OUTPUT_RAW drives a motor in the lap when all its values lie in this range (µs): 0 is an
#: unused channel, 65535 ArduPilot's "no output".
MOTOR_PWM_US = (800.0, 2200.0)


def motor_oscillation(t_s: np.ndarray, pwm: np.ndarray, cutoff_hz: float = CUTOFF_HZ) -> dict[str, Any]:
    """Motor oscillation of one lap: ``t_s`` (n,) sample times (s, increasing), ``pwm`` (n, k) SERVO_OUTPUT_RAW
    outputs (µs). Returns ``motor_osc_us`` (RMS over the lap of the motors' outputs high-passed above
    ``cutoff_hz``, as the square root of the motors' mean square; None with ``motor_note`` when not measured),
    ``motors`` (channels counted) and ``motor_rate_hz``."""
    t, p = np.asarray(t_s, dtype=float), np.asarray(pwm, dtype=float)
    p = p.reshape(len(t), -1) if len(t) else p.reshape(0, 1)
    lo, hi = MOTOR_PWM_US
    motors = np.all((p >= lo) & (p <= hi), axis=0) & (np.ptp(p, axis=0) > 0 if len(t) else False)
    out: dict[str, Any] = {"motor_osc_us": None, "motors": int(motors.sum()), "motor_rate_hz": 0.0}
    if not motors.any():
        return {**out, "motor_note": "no SERVO_OUTPUT_RAW channel drove a motor in the scored lap"}
    total, rate, why = _highpass_rms(t, p[:, motors], cutoff_hz, "SERVO_OUTPUT_RAW")
    out["motor_rate_hz"] = rate
    if total is None:
        return {**out, "motor_note": why}
    out["motor_osc_us"] = total / float(np.sqrt(motors.sum()))
    return out


def smooth_penalty(rough: float | None, rough_ref: float | None, weight: float, band: float = 0.0) -> float:
    """The smoothness term ``w max(0, rough - rough_ref - band r) / r``, ``r = max(rough_ref, FLOOR_DPS)`` (0 when
    either roughness is unknown)."""
    if weight <= 0 or rough is None or rough_ref is None or not np.isfinite(rough) or not np.isfinite(rough_ref):
        return 0.0
    r = max(rough_ref, FLOOR_DPS)
    return float(weight * max(0.0, rough - rough_ref - band * r) / r)
