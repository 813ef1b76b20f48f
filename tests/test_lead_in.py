"""The figure-8 lead-in (ksbo_task.lead_in): the 3-D mission starts from rest and joins the pattern smoothly, and
the MAVLink mission, the in-process copter and the flight-log reference fly the same reference."""

from __future__ import annotations

import numpy as np
import pytest

from ksbo_mav.errors import InputError
from ksbo_mav.mav.mission import Mission
from ksbo_mav.profile_sections import MissionSpec
from ksbo_mav.profiles import load_profile
from ksbo_task.figure8_ne import Figure8H
from ksbo_task.lead_in import lead_in_phase


def test_phase_starts_from_rest_and_joins_the_pattern_half_the_lead_in_late() -> None:
    T = 5.0
    ph, rate, rate_dot = lead_in_phase(np.array([0.0, T, 2 * T, 30.0]), T)
    np.testing.assert_allclose(ph, [0.0, T / 2, 1.5 * T, 30.0 - T / 2])
    np.testing.assert_allclose(rate, [0.0, 1.0, 1.0, 1.0])
    np.testing.assert_allclose(rate_dot, [0.0, 0.0, 0.0, 0.0], atol=1e-12)
    # no lead-in: the identity
    t = np.linspace(0, 3, 7)
    np.testing.assert_array_equal(lead_in_phase(t, 0.0)[0], t)


def test_reference_is_continuous_and_its_derivatives_match_finite_differences() -> None:
    f = Figure8H(lead_in=5.0)
    h = 1e-4
    t = np.concatenate([np.linspace(0.0, 12.0, 241), [5.0 - 1e-9, 5.0 + 1e-9]])
    t = t[t > h]
    vel_fd = (f.position(t + h) - f.position(t - h)) / (2 * h)
    acc_fd = (f.velocity(t + h) - f.velocity(t - h)) / (2 * h)
    np.testing.assert_allclose(f.velocity(t), vel_fd, atol=1e-5)
    np.testing.assert_allclose(f.acceleration(t), acc_fd, atol=1e-4)
    np.testing.assert_allclose(f.velocity(0.0), 0.0, atol=1e-12)  # from rest: no velocity step
    np.testing.assert_allclose(f.acceleration(0.0), 0.0, atol=1e-12)
    # the peak acceleration stays near the pattern's own (1.0 m/s^2 per axis), far below the old step
    acc = np.linalg.norm(f.acceleration(np.linspace(0, 40, 4001)), axis=-1)
    assert acc.max() < 2.0
    # after the lead-in: the pattern, T/2 late
    plain = Figure8H()
    t2 = np.linspace(5.0, 40.0, 50)
    np.testing.assert_allclose(f.position(t2), plain.position(t2 - 2.5), atol=1e-12)


def test_mission_and_copter_fly_the_same_reference() -> None:
    prof = load_profile("px4-copter")
    m = Mission.from_profile(prof)
    assert m.lead_in == prof.mission_spec.lead_in_s == 5.0
    for t in (0.0, 0.7, 4.99, 5.0, 13.3, 39.98):
        p, v, a = m.setpoint_at(t)
        np.testing.assert_allclose(p, m.figure8h.position(t))
        np.testing.assert_allclose(v, m.figure8h.velocity(t))
        np.testing.assert_allclose(a, m.figure8h.acceleration(t))
    np.testing.assert_allclose(m.setpoint_at(0.0)[1], 0.0, atol=1e-12)
    np.testing.assert_allclose(m.start_ned(), [0.0, 0.0, -10.0], atol=1e-12)


@pytest.mark.parametrize("kw, msg", [
    ({"type": "figure8-ne", "lead_in_s": -1.0}, "lead_in_s must be in"),
    ({"type": "figure8-ne", "lead_in_s": 20.0}, "lead_in_s must be in"),  # would eat into the scored lap
    ({"type": "figure8-ne", "lead_in_s": float("nan")}, "lead_in_s must be in"),
    ({"type": "figure8-xz", "lead_in_s": 1.0}, "figure8-ne missions only"),
])
def test_bad_lead_in_is_a_clear_error(kw, msg) -> None:
    with pytest.raises(InputError, match=msg):
        MissionSpec(**kw)
