"""The lap's smoothness (ksbo_mav.smoothness) on signals whose answer is known, and the score's smoothness term."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ksbo_mav.smoothness import motor_oscillation, smooth_penalty, smoothness


def _lap(rate_hz: float = 50.0, seconds: float = 15.0, shake_dps: float = 0.0, shake_hz: float = 6.0):
    t = np.arange(0.0, seconds, 1.0 / rate_hz)
    w = 2 * math.pi / seconds  # one figure-8 lap: slow manoeuvring, 25 deg/s of body rate
    p = np.radians(25.0 * np.cos(w * t) + shake_dps * np.sin(2 * math.pi * shake_hz * t))
    q = np.radians(25.0 * np.sin(2 * w * t))
    roll, pitch = np.radians(12.0) * np.sin(w * t), np.radians(9.0) * np.sin(2 * w * t)
    return t, np.stack([roll, pitch, p, q], axis=1)


def test_the_manoeuvring_of_a_lap_is_not_roughness_and_a_shake_on_top_of_it_is():
    calm = smoothness(*_lap())
    assert calm["rough_dps"] < 0.05  # 25 deg/s of slow rates leave nothing above 2 Hz
    shaken = smoothness(*_lap(shake_dps=3.0))
    assert shaken["rough_dps"] == pytest.approx(3.0 / math.sqrt(2), rel=0.03)  # the shake's RMS
    assert 12.0 <= calm["tilt_max_deg"] <= 15.0 and calm["att_rate_hz"] == pytest.approx(50.0, rel=0.01)


def test_a_stream_too_slow_or_a_lap_too_short_measures_nothing_and_says_why():
    slow = smoothness(*_lap(rate_hz=5.0, shake_dps=3.0))
    assert slow["rough_dps"] is None and "ATTITUDE at 5.0 Hz" in slow["rough_note"]
    t, att = _lap()
    short = smoothness(t[:40], att[:40])
    assert short["rough_dps"] is None and "too short" in short["rough_note"]
    none = smoothness(t[:1], att[:1])
    assert none["rough_dps"] is None and none["tilt_max_deg"] is None
    gappy = att.copy()
    gappy[::3] = np.nan  # missing samples are left out, not taken for a shake
    assert smoothness(t, gappy)["rough_dps"] < 0.1


def test_the_penalty_counts_only_roughness_beyond_the_baselines():
    assert smooth_penalty(3.0, 2.0, 0.5) == pytest.approx(0.25)
    assert smooth_penalty(1.0, 2.0, 0.5) == 0.0  # smoother than the baseline: no reward, tracking decides
    assert smooth_penalty(3.0, None, 0.5) == smooth_penalty(None, 2.0, 0.5) == smooth_penalty(3.0, 2.0, 0.0) == 0.0
    assert smooth_penalty(3.0, 2.0, 0.5, band=0.15) == pytest.approx(0.5 * (1.0 - 0.3) / 2.0)  # past the band
    assert smooth_penalty(1.6, 0.1, 0.5, band=0.15) == pytest.approx(0.5 * (1.5 - 0.15) / 1.0)  # the floor, 1 deg/s


def test_the_copter_score_keeps_the_baseline_at_one_half_and_charges_a_rough_lap():
    from ksbo_mav.mav.mission import Mission
    from ksbo_mav.profiles import load_profile
    from ksbo_task.flight import Trajectory

    mission = Mission.from_profile(load_profile("ardupilot-copter"))
    weight, band = dict(mission.score_section)["smooth_weight"], dict(mission.score_section)["rough_band"]
    assert weight > 0 and 0 < band < 0.5  # the copter profiles optimise smooth tracking, past the measure's scatter
    lo, hi = mission.window
    t = (np.arange(hi) + 1) * mission.dt
    err = np.zeros((hi, 6))
    err[:, 0] = 0.1  # 0.1 m off all along

    def traj() -> Trajectory:
        return Trajectory(t=t, steps=np.arange(hi), states=err, refs=np.zeros((hi, 6)), inputs=None, L=hi,
                          source="test")

    base = mission.score(traj(), rms_ref=0.1, smooth={"rough_dps": 2.0}, rough_ref=2.0)
    assert base["P"] == pytest.approx(0.5) and base["smooth_penalty"] == 0.0
    ratio = base["unsafe_rms_ratio"]
    rough = mission.score(traj(), rms_ref=0.2, smooth={"rough_dps": 4.0, "tilt_max_deg": 20.0}, rough_ref=2.0)
    # tracking twice as good as the baseline, twice as rough: P = 1 - (0.5 + w (2 - 1 - band)) / ratio
    assert rough["P"] == pytest.approx(1.0 - (0.5 + weight * (1.0 - band)) / ratio)
    within = mission.score(traj(), rms_ref=0.2, smooth={"rough_dps": 2.0 * (1 + 0.9 * band)}, rough_ref=2.0)
    assert within["smooth_penalty"] == 0.0  # rougher by less than the scatter of the measure: not charged
    assert rough["rough_dps"] == 4.0 and rough["rough_ref_dps"] == 2.0 and rough["tilt_max_deg"] == 20.0
    blind = mission.score(traj(), rms_ref=0.2, smooth={"rough_dps": None, "rough_note": "slow"}, rough_ref=2.0)
    assert blind["P"] == pytest.approx(1.0 - 0.5 / ratio) and blind["rough_note"] == "slow"


def test_a_negative_weight_or_cutoff_is_refused_in_one_line():
    from ksbo_mav.errors import InputError
    from ksbo_mav.profile_sections import ScoreSpec

    with pytest.raises(InputError, match="smooth_weight must be >= 0"):
        ScoreSpec(smooth_weight=-0.5)
    with pytest.raises(InputError, match="rough_cutoff_hz must be positive"):
        ScoreSpec(rough_cutoff_hz=0.0)
    with pytest.raises(InputError, match=r"rough_band must be in \[0, 1\)"):
        ScoreSpec(rough_band=1.0)


def test_motor_oscillation_is_the_motors_shake_above_the_cutoff_and_skips_unused_channels():
    t = np.arange(0.0, 15.0, 0.02)
    slow = 1500 + 80 * np.sin(2 * math.pi * t / 15.0)  # the lap's own throttle changes: below the cutoff
    shake = 30.0 * np.sin(2 * math.pi * 7.0 * t)  # 30 us at 7 Hz, opposite on the two diagonals
    motors = np.stack([slow + shake, slow - shake, slow + shake, slow - shake], axis=1)
    unused = np.stack([np.zeros_like(t), np.full_like(t, 65535.0), np.full_like(t, 1500.0), np.zeros_like(t)], axis=1)
    out = motor_oscillation(t, np.concatenate([motors, unused], axis=1))
    assert out["motors"] == 4  # 0, 65535 and a constant output drive no motor
    assert out["motor_osc_us"] == pytest.approx(30.0 / math.sqrt(2), rel=0.03)  # the shake's RMS per motor
    calm = motor_oscillation(t, np.concatenate([np.stack([slow] * 4, axis=1), unused], axis=1))
    assert calm["motor_osc_us"] < 0.5
    ten_hz = motor_oscillation(t[::10], motors[::10])
    assert ten_hz["motor_osc_us"] is None and "SERVO_OUTPUT_RAW at 5.0 Hz" in ten_hz["motor_note"]
    assert motor_oscillation(t, unused)["motor_note"].startswith("no SERVO_OUTPUT_RAW channel")


def test_a_32_bit_microsecond_stamp_is_read_near_the_vehicle_clock():
    from ksbo_mav.mav.trajectory import _near_ms

    assert _near_ms(123_456_000, 123_450) == pytest.approx(123_456.0)
    boot_ms = (1 << 32) // 1000 + 5_000  # 71.6 min after boot ArduPilot's micros32 has wrapped
    wrapped = (boot_ms * 1000 + 20_000) % (1 << 32)
    assert _near_ms(wrapped, boot_ms) == pytest.approx(boot_ms + 20.0)
