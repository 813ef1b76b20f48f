"""The validation manoeuvres' figures on synthetic flights whose answers are known by construction."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ksbo_task.manoeuvre_metrics import assign_legs, cross_track, hold_drift, mission_tracking, step_response


def _first_order_step(tau: float, size: float, t: np.ndarray) -> np.ndarray:
    """A 1st-order response to a north step of ``size`` at t = 0: no overshoot, 10-90 % in tau ln 9."""
    n = size * (1.0 - np.exp(-t / tau))
    return np.column_stack([n, np.zeros_like(t), np.full_like(t, -10.0)])


def test_first_order_step_rise_settle_and_no_overshoot():
    t = np.arange(0.0, 20.0, 0.001)
    pos = _first_order_step(1.0, 5.0, t)
    r = step_response(t, pos, np.array([0, 0, -10.0]), np.array([5.0, 0, -10.0]), 0.0)
    assert r["size_m"] == 5.0
    assert r["rise_s"] == pytest.approx(math.log(9.0), abs=2e-3)
    assert r["overshoot_pct"] == 0.0
    # band max(5 % of 5 m, 0.1 m) = 0.25 m: 5 e^-t = 0.25 at t = ln 20
    assert r["settle_s"] == pytest.approx(math.log(20.0), abs=2e-3)
    tight = step_response(t, pos, np.array([0, 0, -10.0]), np.array([5.0, 0, -10.0]), 0.0,
                          settle_fraction=0.02, settle_floor_m=0.0)
    assert tight["settle_s"] == pytest.approx(math.log(50.0), abs=2e-3)


def test_underdamped_step_overshoot_matches_the_second_order_formula():
    zeta, wn = 0.3, 2.0
    wd = wn * math.sqrt(1 - zeta ** 2)
    t = np.arange(0.0, 30.0, 0.001)
    y = 1 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta ** 2) * np.sin(wd * t))
    start, target = np.array([1.0, 2.0, -10.0]), np.array([1.0, 2.0, -12.0])  # 2 m up
    pos = start + y[:, None] * (target - start)
    r = step_response(t + 5.0, pos, start, target, 5.0)
    assert r["overshoot_pct"] == pytest.approx(100 * math.exp(-zeta * math.pi / math.sqrt(1 - zeta ** 2)), abs=0.01)
    assert 0 < r["rise_s"] < math.pi / wd  # the first crossing of 90 % comes before the peak
    # settles inside 0.1 m (the floor: 5 % of 2 m is less) once the envelope 2 e^(-zeta wn t) / sqrt(1-zeta^2) ...
    env = -math.log(0.1 * math.sqrt(1 - zeta ** 2) / 2.0) / (zeta * wn)
    assert 0 < r["settle_s"] <= env


def test_a_step_that_never_settles_or_never_rises():
    t = np.linspace(0, 10, 1001)
    pos = np.column_stack([0.5 * np.ones_like(t), np.zeros_like(t), np.zeros_like(t)])  # stuck at 10 %
    r = step_response(t, pos, np.zeros(3), np.array([5.0, 0, 0]), 0.0)
    assert math.isnan(r["rise_s"]) and math.isnan(r["settle_s"]) and r["overshoot_pct"] == 0.0


def test_hold_drift_of_a_circle_and_a_constant_offset():
    th = np.linspace(0, 2 * np.pi, 2000, endpoint=False)
    pos = np.column_stack([0.3 * np.cos(th), 0.3 * np.sin(th), np.full_like(th, -10.2)])
    d = hold_drift(pos, np.array([0.0, 0.0, -10.0]))
    assert d["rms_m"] == pytest.approx(0.3) and d["max_m"] == pytest.approx(0.3)
    assert d["vert_rms_m"] == pytest.approx(0.2)
    walk = np.column_stack([np.linspace(0, 1, 101), np.zeros(101), np.zeros(101)])
    d = hold_drift(walk, np.zeros(3))
    assert d["max_m"] == pytest.approx(1.0) and d["rms_m"] == pytest.approx(math.sqrt(np.mean(walk[:, 0] ** 2)))


BOX = np.array([[0, 0, -10], [8, 0, -10], [8, 5, -10], [0, 5, -10], [0, 0, -10.0]])


def _path(points: list[tuple[float, float]], speed: float = 2.0, dt: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """Constant-speed polyline through ``points`` (NE) at 10 m up."""
    pts = [np.array(p, float) for p in points]
    out = [pts[0]]
    for a, b in zip(pts, pts[1:]):
        n = max(1, int(round(np.linalg.norm(b - a) / (speed * dt))))
        out += [a + (b - a) * k / n for k in range(1, n + 1)]
    ne = np.array(out)
    pos = np.column_stack([ne, np.full(len(ne), -10.0)])
    return np.arange(len(pos)) * dt, pos


def test_a_path_on_the_legs_has_no_cross_track_and_its_time():
    t, pos = _path([(0, 0), (8, 0), (8, 5), (0, 5), (0, 0)])
    m = mission_tracking(t, pos, BOX)
    assert m["xtrack_rms_m"] == pytest.approx(0.0, abs=1e-9) and m["xtrack_max_m"] == pytest.approx(0.0, abs=1e-9)
    assert m["vert_rms_m"] == pytest.approx(0.0, abs=1e-12)
    for c in (1, 2, 3):
        assert m[f"corner{c}_overshoot_m"] == pytest.approx(0.0, abs=1e-9) and m[f"corner{c}_settle_s"] == 0.0
    # 26 m at 2 m/s; the last 0.5 m (arrive_m) are not needed
    assert m["time_s"] == pytest.approx(25.5 / 2.0, abs=0.02)
    assert m["corners_unsettled"] == 0.0


def test_overshooting_each_corner_by_a_known_distance():
    # past each corner by 0.6 m in the incoming direction, then back onto the next leg 0.6 m off it and along it
    t, pos = _path([(0, 0), (8.6, 0), (8.6, 0.3), (8, 0.6), (8, 5), (7.4, 5.6), (0, 5.6)])
    m = mission_tracking(t, pos, BOX[:4], settle_band_m=0.2)
    assert m["corner1_overshoot_m"] == pytest.approx(0.6, abs=1e-9)
    assert m["corner2_overshoot_m"] == pytest.approx(0.6, abs=1e-9)
    assert m["xtrack_max_m"] == pytest.approx(0.6, abs=1e-9)
    # corner 1: crossed at x = 8.01 m (t 4.01 s), back within 0.2 m of leg 2 two thirds down the 0.67 m segment
    # from (8.6, 0.3) to (8, 0.6) (t 4.68 s)
    assert m["corner1_settle_s"] == pytest.approx(0.67, abs=0.02)
    assert math.isnan(m["corner2_settle_s"])  # leg 3 is flown 0.6 m off to its end
    assert math.isnan(m["time_s"])  # and never arrives
    assert m["corners_unsettled"] == 1.0


def test_leg_assignment_follows_the_bisector_and_cross_track_is_to_the_segment():
    pos = np.array([[7.0, 0.0, 0], [7.9, 0.05, 0], [7.9, 0.2, 0], [8.0, 3.0, 0]])
    assert list(assign_legs(pos, BOX)) == [0, 0, 1, 1]
    assert list(cross_track(np.array([[4.0, 0.5, 0], [10.0, 0.0, 0], [-3.0, -4.0, 0]]), BOX[0], BOX[1])) == \
        pytest.approx([0.5, 2.0, 5.0])


def test_a_corner_settles_though_the_next_corner_is_cut():
    # leg 2 is flown on its line, then corner 2 is cut from (8, 4) to (7, 5): half a metre off leg 2 at the end
    t, pos = _path([(0, 0), (8, 0), (8, 4), (7, 5), (0, 5)])
    m = mission_tracking(t, pos, BOX[:4])
    assert m["xtrack_max_m"] == pytest.approx(0.5, abs=0.02)
    assert m["corner1_settle_s"] == 0.0 and m["corner1_overshoot_m"] == 0.0
    assert m["corner2_overshoot_m"] == 0.0 and m["final_overshoot_m"] == 0.0
