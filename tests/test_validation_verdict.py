"""The validation verdict on numbers: the rule (difference beyond the repeats' spread), aborts, the fallback figure,
the recommendation's refusal line and the best candidate; which vehicles estimate their wind; the wind inferred
from a flight's lean angle against its ground velocity, on a flight simulated with a known wind and drag."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ksbo_mav.campaign import validation_verdicts
from ksbo_mav.campaign.validation_log import ValidationEntry, ValidationJournal
from ksbo_mav.campaign.verdict import (BETTER, SAME, UNMEASURED, WORSE, best_not_worse, judge, judge_pairs,
                                       refusal)
from ksbo_mav.flightlog.wind_fit import G, fit_wind, wind_from_lean
from ksbo_mav.mav.outcome import TrialOutcome
from ksbo_mav.mav.wind_source import wind_estimated


@pytest.mark.parametrize("base, cand, verdict", [
    ([0.20, 0.22], [0.30, 0.31], WORSE),  # +0.095 beyond the spread 0.02
    ([0.20, 0.22], [0.12, 0.13], BETTER),
    ([0.20, 0.22], [0.215, 0.23], SAME),  # +0.0125 within the spread 0.02
    ([0.20, 0.30], [0.24, 0.33], SAME),  # +0.035 within a wide baseline spread 0.10
    ([0.200, 0.200], [0.203, 0.203], SAME),  # identical repeats: within the 2 % resolution
    ([0.200, 0.200], [0.210, 0.210], WORSE),  # 5 % beyond it
    ([0.20], [0.30, 0.31], UNMEASURED),  # one baseline flight measures no spread
])
def test_difference_beyond_the_repeats_spread(base, cand, verdict):
    assert judge(base, cand).verdict == verdict


def test_aborted_flights_decide_against_their_gains():
    assert judge([0.2, 0.21], [0.1], cand_aborted=1).verdict == WORSE
    assert judge([0.2], [0.1, 0.1], base_aborted=1).verdict == BETTER
    assert judge([], [], base_aborted=2, cand_aborted=2).verdict == UNMEASURED


def _entry(n, manoeuvre, pair, gains, value, outcome="ok", metric=None):
    metric = metric or {"hold": "hold_rms_m", "steps": "settle_s_mean", "auto_mission": "xtrack_rms_m"}[manoeuvre]
    x = (1.0, 2.0) if gains == "baseline" else (1.5, float(n))
    return ValidationEntry(flight=n, manoeuvre=manoeuvre, pair=pair, gains=gains, x=x, outcome=TrialOutcome(outcome),
                           metrics={} if value is None else {metric: value}, tlog=f"flight_{n:03d}.tlog",
                           restored=True)


def _pair(pair, n0, figures):
    """A B A B entries of ``pair`` from {manoeuvre: (baseline figures, candidate figures)}."""
    out, n = [], n0
    for m, (a, b) in figures.items():
        for x, y in zip(a, b):
            out += [_entry(n, m, pair, "baseline", x), _entry(n + 1, m, pair, pair, y)]
            n += 2
    return out


def test_a_recommendation_worse_on_a_manoeuvre_is_refused_and_the_best_candidate_named(tmp_path):
    entries = (_pair("recommendation", 0, {"hold": ([0.20, 0.21], [0.35, 0.36]), "auto_mission": ([0.5, 0.5],
                                                                                                   [0.3, 0.31])})
               + _pair("trial 7", 8, {"hold": ([0.21, 0.20], [0.18, 0.19]), "auto_mission": ([0.5, 0.51],
                                                                                             [0.42, 0.41])}))
    journal = ValidationJournal(tmp_path / "validation.jsonl")
    for e in entries:
        journal.append(e)
    verdicts = judge_pairs(ValidationJournal(tmp_path / "validation.jsonl").entries)  # read back from disk
    assert [p.pair for p in verdicts] == ["recommendation", "trial 7"]
    assert verdicts[0].worse_on == ["hold"] and verdicts[0].overall == WORSE
    assert verdicts[1].overall == BETTER and best_not_worse(verdicts).pair == "trial 7"
    as_json = validation_verdicts(tmp_path)  # what a script reads back from the campaign directory
    assert [p["overall"] for p in as_json] == [WORSE, BETTER]
    assert as_json[0]["manoeuvres"]["hold"]["baseline"] == [0.20, 0.21] and as_json[0]["manoeuvres"]["hold"][
        "metric"] == "hold_rms_m"
    line = refusal(verdicts)
    assert "\n" not in line and "hold: worse (hold_rms_m 0.205 -> 0.355" in line
    assert "best candidate worse nowhere: trial 7" in line and "auto_mission" not in line


def test_no_refusal_when_the_recommendation_is_worse_nowhere():
    entries = _pair("recommendation", 0, {"hold": ([0.20, 0.21], [0.205, 0.2])})
    verdicts = judge_pairs(entries)
    assert verdicts[0].overall == SAME and refusal(verdicts) is None


def test_flights_not_counted_do_not_enter_the_verdict_and_steps_fall_back_to_overshoot():
    entries = [_entry(0, "steps", "recommendation", "baseline", 12.0, metric="overshoot_pct_mean"),
               _entry(1, "steps", "recommendation", "recommendation", None, outcome="link"),  # not the gains
               _entry(2, "steps", "recommendation", "recommendation", 9.0, metric="overshoot_pct_mean"),
               _entry(3, "steps", "recommendation", "baseline", 12.2, metric="overshoot_pct_mean"),
               _entry(4, "steps", "recommendation", "recommendation", 9.1, metric="overshoot_pct_mean")]
    j = judge_pairs(entries)[0].judged["steps"]
    assert j.metric == "overshoot_pct_mean" and j.cand == (9.0, 9.1) and j.verdict == BETTER


@pytest.mark.parametrize("stack, params, estimated", [
    ("ardupilot", {"AHRS_EKF_TYPE": 3, "EK3_DRAG_BCOEF_X": 0.0, "EK3_DRAG_BCOEF_Y": 0.0, "EK3_DRAG_MCOEF": 0.0},
     False),
    ("ardupilot", {"AHRS_EKF_TYPE": 3, "EK3_DRAG_BCOEF_X": 20.0, "EK3_DRAG_BCOEF_Y": 25.0}, True),
    ("ardupilot", {"AHRS_EKF_TYPE": 3, "EK3_DRAG_MCOEF": 0.2}, True),
    ("ardupilot", {"AHRS_EKF_TYPE": 3, "ARSPD_TYPE": 1, "ARSPD_USE": 1}, True),
    ("ardupilot", {"AHRS_EKF_TYPE": 10}, None),
    ("px4", {"EKF2_DRAG_CTRL": 0, "EKF2_ARSP_THR": 0.0}, False),
    ("px4", {"EKF2_DRAG_CTRL": 1}, True),
    ("px4", {}, None),
])
def test_which_vehicles_estimate_their_wind(stack, params, estimated):
    assert wind_estimated(stack, params) == estimated


def _flight(wind, c_lin=0.25, c_quad=0.03, seconds=60.0, hover=False, seed=0):
    """A copter flying a figure-8 (or hovering) in ``wind`` (north, east m/s) under the drag model, its attitude
    what holds that path: t (n,), NED velocity (n, 3), roll/pitch/yaw (n, 3), with sensor noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, seconds, 0.02)
    w = 2 * math.pi / 20.0
    scale = 0.0 if hover else 1.0
    vel = np.column_stack([scale * 10 * w * np.cos(w * t), scale * 2.5 * 2 * w * np.cos(2 * w * t), 0 * t])
    acc = np.column_stack([-scale * 10 * w * w * np.sin(w * t), -scale * 2.5 * 4 * w * w * np.sin(2 * w * t), 0 * t])
    va = vel[:, :2] - np.asarray(wind, float)
    drag = -(c_lin + c_quad * np.linalg.norm(va, axis=1))[:, None] * va
    yaw = 0.3 + 0.1 * np.sin(0.2 * t)
    f = np.column_stack([acc[:, :2] - drag, -G * np.ones_like(t)])  # thrust's specific force, NED
    up = -f / np.linalg.norm(f, axis=1)[:, None]  # body up axis (NED), the third column of R
    # Solve R[:, 2] = up for roll and pitch at the given yaw.
    cy, sy = np.cos(yaw), np.sin(yaw)
    a, b = cy * up[:, 0] + sy * up[:, 1], sy * up[:, 0] - cy * up[:, 1]  # cos(r) sin(p), sin(r)
    roll = np.arcsin(np.clip(b, -1, 1))
    pitch = np.arctan2(a, up[:, 2])
    att = np.column_stack([roll, pitch, yaw]) + rng.normal(0, 0.002, (t.size, 3))
    return t, vel + rng.normal(0, 0.03, vel.shape), att


@pytest.mark.parametrize("wind", [(0.0, 0.0), (-5.0, 0.0), (2.0, 3.5)])
def test_the_wind_is_inferred_from_the_lean_angle_against_the_ground_velocity(wind):
    fit = fit_wind(*_flight(wind))
    assert fit is not None
    assert fit.north == pytest.approx(wind[0], abs=0.3) and fit.east == pytest.approx(wind[1], abs=0.3)
    if wind == (-5.0, 0.0):
        assert fit.from_deg == pytest.approx(0.0, abs=5.0) or fit.from_deg == pytest.approx(360.0, abs=5.0)


def test_a_hover_alone_cannot_tell_wind_from_drag_but_the_lean_with_known_drag_can():
    hover = _flight((0.0, 4.0), hover=True)
    assert fit_wind(*hover) is None  # the ground velocity never changed
    moving = fit_wind(*_flight((0.0, 4.0)))
    lean = wind_from_lean(*hover, moving.c_lin, moving.c_quad)
    assert lean.east == pytest.approx(4.0, abs=0.3) and abs(lean.north) < 0.3
