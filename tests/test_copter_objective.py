"""Issue 13's plant suite: the JSBSim copter as an in-process objective scores like a MAVLink campaign (baseline
P = 0.5, P = 1 − RMS / (2 RMS_baseline)), searches the campaign's trust region, and turns a flight that breaks the
profile's [safety] limits into an aborted (censored) trial."""

from __future__ import annotations

import numpy as np
import pytest

from ksbo_mav.copter_objective import COPTER_PLANTS, CopterObjective
from ksbo_mav.mav.gains import trust_region
from ksbo_mav.opt.outcome import Outcome


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


def test_flight_outside_the_safety_limits_is_aborted_with_the_reason(px4) -> None:
    rms, outcome, why = px4.flight(px4.bounds[:, 1])  # every gain at the top of the box: > 40 deg tilt
    assert outcome is Outcome.ABORTED and "tilt" in why
    ev = px4(px4.bounds[:, 1])
    assert ev.censored
    P, counts = px4.expected_outcomes(np.vstack([px4.baseline, px4.bounds[:, 1]]))
    assert P[0] == pytest.approx(0.5) and np.isnan(P[1])
    assert counts.tolist() == [[1, 0, 0], [0, 1, 0]]


def test_unknown_plant_names_the_known_ones() -> None:
    with pytest.raises(KeyError, match="copter3d-ardupilot"):
        CopterObjective("copter3d-betaflight")
    assert set(COPTER_PLANTS) == {"copter3d-ardupilot", "copter3d-px4"}
