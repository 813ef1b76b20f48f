"""The plant suite: the JSBSim copter as an in-process objective scores like a MAVLink campaign (baseline
P = 0.5, P = 1 − RMS / (2 RMS_baseline)), searches the campaign's trust region, and turns a flight that breaks the
profile's [safety] limits into an aborted (censored) trial."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ksbo_mav.mav.gains import trust_region
from ksbo_mav.opt.evaluation import Outcome
from ksbo_mav.simulated.copter_objective import COPTER_PLANTS, CopterObjective


@pytest.fixture(scope="module")
def px4() -> CopterObjective:
    return CopterObjective("copter3d-px4")


def test_baseline_scores_one_half_and_flights_are_deterministic(px4) -> None:
    ev = px4(px4.baseline)
    assert ev.outcome is Outcome.COMPLETE and ev.value == pytest.approx(0.5, abs=1e-9)
    faster = px4.baseline.copy()
    faster[0] *= 1.5  # MPC_XY_P up: tighter tracking
    a, b = px4(faster), px4(faster)
    assert a.value == b.value and a.value > 0.5
    assert px4.n_flights == 4  # the baseline at construction, then three


def test_search_box_is_the_campaigns_trust_region(px4) -> None:
    lo, hi = trust_region(px4.profile, px4.baseline)
    np.testing.assert_array_equal(px4.bounds, np.column_stack([lo, hi]))


def test_the_lead_in_removes_the_start_transient_that_tripped_the_tilt_limit(px4) -> None:
    from ksbo_sim.copter3d import fly
    from ksbo_task.figure8_ne import Figure8H

    top = px4.bounds[:, 1]  # every gain at the top of the box
    assert px4.figure.lead_in == px4.profile.mission_spec.lead_in_s > 0
    for name, v in zip(px4.profile.names, top):
        px4.vehicle.set_param(name, float(v))
    step_start = fly(px4.vehicle, replace(px4.figure, lead_in=0.0))  # the pattern from t = 0: a 3.5 m/s step
    smooth = fly(px4.vehicle, px4.figure)
    assert step_start.max_tilt_deg > px4.limits.tilt_max_deg  # tripped the 40 deg limit in the first second
    assert smooth.max_tilt_deg < 15.0 and smooth.max_error < 1.0
    # the scored lap is an ordinary lap either way: same steady-state tracking
    assert smooth.rms_lap2 == pytest.approx(step_start.rms_lap2, rel=0.05)
    rms, outcome, why = px4.flight(top)
    assert outcome is Outcome.COMPLETE and why == ""
    assert isinstance(px4.figure, Figure8H)


@pytest.mark.slow  # default run: the monitor's aborts: test_mav_trial
def test_flight_outside_the_safety_limits_is_aborted_with_the_reason() -> None:
    obj = CopterObjective("copter3d-px4")
    obj.limits = replace(obj.limits, tilt_max_deg=5.0)  # a limit the figure-8 itself needs more than
    rms, outcome, why = obj.flight(obj.bounds[:, 1])
    assert outcome is Outcome.ABORTED and "tilt" in why
    ev = obj(obj.bounds[:, 1])
    assert ev.censored
    obj.limits = replace(obj.limits, tilt_max_deg=40.0)
    P, counts = obj.expected_outcomes(np.vstack([obj.baseline, obj.bounds[:, 1]]))
    assert P[0] == pytest.approx(0.5) and P[1] > 0.5
    obj.limits = replace(obj.limits, tilt_max_deg=5.0)
    P, counts = obj.expected_outcomes(np.vstack([obj.baseline, obj.bounds[:, 1]]))
    assert np.isnan(P).all() and counts.tolist() == [[0, 1, 0], [0, 1, 0]]


def test_unknown_plant_names_the_known_ones() -> None:
    with pytest.raises(KeyError, match="copter3d-ardupilot"):
        CopterObjective("copter3d-betaflight")
    assert set(COPTER_PLANTS) == {"copter3d-ardupilot", "copter3d-px4"}
