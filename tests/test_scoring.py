"""P(a) scoring: formula, penalties, configuration."""

import numpy as np
import pytest

from ksbo_mav.errors import InputError
from ksbo_mav.scoring import ScoreConfig, score, stage_costs


def _traj(n=600, err=0.1, L=None):
    steps = np.arange(n)
    refs = np.zeros((n, 6))
    refs[:, 2] = 1.0
    states = refs.copy()
    states[:, 0] += err
    L = n if L is None else L
    states[L:] = np.nan
    inputs = np.full((n, 2), 0.027 * 9.8 / 2)
    return states, refs, steps, L, inputs


def test_complete_episode_gives_scaled_return():
    states, refs, steps, L, u = _traj(err=0.1)
    s = score(states, refs, steps, L, u)
    jq = 300 * 0.5 * 0.01  # lap 2: 300 steps of 1/2 * Q_xx * 0.1^2
    assert s.JQ[0] == pytest.approx(jq)
    assert s.JR[0] == pytest.approx(-jq)
    assert s.JR_scaled[0] == pytest.approx(1 - jq / 5.6)
    assert s.P[0] == pytest.approx(1 - jq / 5.6)
    assert s.complete[0] and s.safe[0]


def test_input_term_uses_R_and_hover_reference():
    states, refs, steps, L, u = _traj(err=0.0)
    u = u + np.array([0.01, -0.02])
    s = score(states, refs, steps, L, u)
    assert s.JQ[0] == pytest.approx(300 * 0.5 * 0.1 * (0.01**2 + 0.02**2))
    assert score(states, refs, steps, L, None).JQ[0] == 0.0


def test_early_stop_penalty_follows_formula():
    states, refs, steps, _, u = _traj(err=0.0, L=450)
    s = score(states, refs, steps, 450, u)
    assert not s.complete[0]
    assert np.isnan(s.JQ[0])
    assert s.JR_scaled[0] == 0.0
    assert s.P[0] == pytest.approx(-(1 - (450 / 600) ** 2))
    assert not s.safe[0]


def test_unsafe_iff_negative_under_defaults():
    # J^Q above J_HI = 5.6 makes P negative on a complete episode; below keeps it positive
    for err, safe in ((0.19, True), (0.2, False)):
        states, refs, steps, L, u = _traj(err=err)
        s = score(states, refs, steps, L, u)
        assert bool(s.safe[0]) is safe
        assert (s.P[0] < 0) is (s.JQ[0] > 5.6)


def test_lambda_and_L_expected_take_effect():
    states, refs, steps, _, u = _traj(err=0.0, L=300)
    p1 = score(states, refs, steps, 300, u, ScoreConfig(lam=0.5)).P[0]
    assert p1 == pytest.approx(-(1 - 0.5 * 0.25))
    p2 = score(states, refs, steps, 300, u, ScoreConfig(L_expected=400)).P[0]
    assert p2 == pytest.approx(-(1 - (300 / 400) ** 2))
    states, refs, steps, L, u = _traj(err=0.1)
    full = score(states, refs, steps, L, u, ScoreConfig(L_expected=800)).P[0]
    assert full == pytest.approx(1 - 1.5 / 5.6 - (1 - (600 / 800) ** 2))


def test_floor_of_scaled_return():
    states, refs, steps, L, u = _traj(err=2.0)
    s = score(states, refs, steps, L, u)
    assert s.JR_scaled[0] == -1.0


def test_missing_samples_in_window_is_incomplete():
    states, refs, steps, L, u = _traj(err=0.0)
    keep = steps != 400
    s = score(states[keep], refs[keep], steps[keep], 600, u[keep])
    assert not s.complete[0]


def test_bad_shapes_raise_clear_error():
    states, refs, steps, L, u = _traj()
    with pytest.raises(InputError):
        score(states[:, :4], refs, steps, L)
    with pytest.raises(InputError):
        score(states, refs, steps[:10], L)
    with pytest.raises(InputError):
        ScoreConfig(Q=(1, 2))


def test_stage_costs_batched():
    states, refs, steps, L, u = _traj(err=0.1)
    c = stage_costs(np.stack([states, states]), refs, np.stack([u, u]))
    assert c.shape == (2, 600)
    np.testing.assert_allclose(c[0], 0.005)
