"""Planar physics, controller and figure-8 reference."""

import math

import numpy as np
import pytest

from ksbo_sim import EpisodeConfig, SCG_CRAZYFLIE, simulate
from ksbo_sim.dynamics import integrate, integrate_stepwise
from ksbo_sim.pid import PlanarPID
from ksbo_task.figure8 import Figure8

C = SCG_CRAZYFLIE


def test_constants_match_safe_control_gym():
    assert C.moment_arm == pytest.approx(0.02807, abs=1e-5)
    assert C.thrust_min == pytest.approx(0.0563, abs=1e-4)
    assert C.thrust_max == pytest.approx(0.2967, abs=1e-4)
    assert C.hover_thrust == pytest.approx(0.1323, abs=1e-4)
    assert 2 * C.thrust_max / (C.mass * C.g) == pytest.approx(2.24, abs=0.01)


def test_hover_thrust_keeps_vehicle_still():
    s0 = np.array([[0.3, 0.0, 1.0, 0.0, 0.0, 0.0]])
    u = np.full((1, 2), C.hover_thrust)
    s = s0
    for _ in range(500):  # 10 s
        s = integrate(s, u, C, 0.02, 20)
    np.testing.assert_allclose(s, s0, atol=1e-9)


def test_free_fall_matches_g():
    s0 = np.array([[0.0, 0.0, 1.0, 0.0, 0.0, 0.0]])
    s = integrate(s0, np.zeros((1, 2)), C, 0.02, 20)
    h, n = 0.001, 20
    # Semi-implicit Euler: v = -g n h, z = z0 - g h^2 n (n + 1) / 2 (-> -g t^2 / 2 as h -> 0).
    assert s[0, 3] == pytest.approx(-C.g * 0.02, rel=1e-12)
    assert s[0, 2] == pytest.approx(1.0 - C.g * h * h * n * (n + 1) / 2, rel=1e-12)
    for _ in range(49):  # 1 s of free fall: z drop -> g t^2 / 2 up to the O(h / t) = 0.1 % Euler error
        s = integrate(s, np.zeros((1, 2)), C, 0.02, 20)
    assert 1.0 - s[0, 2] == pytest.approx(0.5 * C.g, rel=2e-3)


def test_pitch_accelerates_x_and_differential_thrust_pitches():
    s0 = np.array([[0.0, 0.0, 1.0, 0.0, 0.1, 0.0]])
    s = integrate(s0, np.full((1, 2), C.hover_thrust), C, 0.02, 20)
    assert s[0, 1] > 0.0  # positive pitch -> +x acceleration
    s = integrate(np.zeros((1, 6)), np.array([[0.10, 0.12]]), C, 0.02, 20)
    assert s[0, 5] == pytest.approx(0.02 * 0.02 * C.moment_arm / C.iyy, rel=1e-12)


def test_closed_form_substeps_equal_stepwise_integration():
    rng = np.random.default_rng(3)
    s0 = rng.normal(size=(200, 6))
    u = rng.uniform(C.thrust_min, C.thrust_max, size=(200, 2))
    np.testing.assert_allclose(integrate(s0, u, C, 0.02, 20), integrate_stepwise(s0, u, C, 0.02, 20),
                               rtol=1e-12, atol=1e-12)


def test_figure8_reference_matches_formula():
    f = Figure8()
    t = np.linspace(0, 12, 601)
    w = 2 * math.pi / 6
    p, v = f.position(t), f.velocity(t)
    np.testing.assert_allclose(p[:, 0], 0.75 * np.sin(w * t), atol=1e-15)
    np.testing.assert_allclose(p[:, 1], 1 + 0.75 * np.sin(w * t) * np.cos(w * t), atol=1e-15)
    # analytic velocity equals the numerical derivative of the position
    eps = 1e-6
    np.testing.assert_allclose(v, (f.position(t + eps) - f.position(t - eps)) / (2 * eps), atol=1e-7)
    np.testing.assert_allclose(f.acceleration(t), (f.velocity(t + eps) - f.velocity(t - eps)) / (2 * eps), atol=1e-6)


def test_episode_length_and_reference_timing():
    cfg = EpisodeConfig()
    assert cfg.steps == 600 and cfg.n_sub == 20
    refs = cfg.reference()
    assert refs.shape == (601, 6)
    np.testing.assert_allclose(refs[:, 0], cfg.figure8.position(np.arange(601) * 0.02)[:, 0])


def test_controller_sees_step_k_reference():
    """With the reference of step k the first PID output depends on X_GOAL[0], not X_GOAL[1]."""
    cfg = EpisodeConfig()
    refs = cfg.reference()
    gains = np.array([[0.15, 0, 0.1, 0.5, 0, 0.2, 3e4, 0, 1e4]])
    init = np.array([0.0, 0.2, 1.0, -0.1, 0.0, 0.0])
    pid = PlanarPID(gains, C, cfg.dt)
    u0 = pid(init[None], refs[0, (0, 2)], refs[0, (1, 3)])
    s1 = integrate(init[None], u0, C, cfg.dt, cfg.n_sub)
    roll = simulate(gains, init, cfg)
    np.testing.assert_array_equal(roll.inputs[0, 0], u0[0])
    np.testing.assert_array_equal(roll.states[0, 1], s1[0])


def test_out_of_bounds_ends_episode_with_reason():
    cfg = EpisodeConfig()
    # zero gains: thrust = m g only (no attitude control) and a sideways start -> leaves |x| <= 2 or tilts
    init = np.array([[0.0, 0.0, 1.0, 0.0, 0.0, 0.0], [1.9, 3.0, 1.0, 0.0, 0.0, 0.0], [0, 0, 0.0, -3.0, 0, 0]])
    roll = simulate(np.array([0.15, 0, 0.1, 0.5, 0, 0.2, 3e4, 0, 1e4]), init, cfg)
    assert roll.L[0] == 600 and roll.reason[0] == 0
    assert roll.L[1] < 600 and roll.reason[1] == 1  # |x| > 2
    assert roll.L[2] < 600 and roll.reason[2] == 2  # ground
    assert np.isnan(roll.states[1, roll.L[1] + 1 :]).all()
