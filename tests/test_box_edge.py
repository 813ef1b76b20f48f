"""Box-edge notes: which gains of a recommendation touch which bound of the search box, and a safe-BO run on the
planar simulator whose box excludes the optimum (the note appears) or contains it (no note)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from ksbo_mav.campaign.box_edge import TOL, EdgeHit, edge_hits, edge_lines

NAMES = ["PSC_POSXY_P", "PSC_VELXY_P", "PSC_VELXY_I"]
BOX = np.array([[0.5, 1.75], [1.0, 3.5], [0.5, 1.0]])  # ArduCopter's trust region around the defaults
LIMITS = np.array([[0.5, 2.0], [1.0, 4.0], [0.1, 1.0]])  # the profile's own gain limits


def test_upper_trust_region_edge_says_the_improvement_may_continue():
    hits = edge_hits([1.75, 2.0, 0.8], BOX, NAMES, limits=LIMITS)
    assert [(h.name, h.side, h.at_limit) for h in hits] == [("PSC_POSXY_P", "upper", False)]
    line = hits[0].message()
    assert line.startswith("PSC_POSXY_P = 1.75 is at the upper bound 1.75 of the search box")
    assert "the profile allows 2" in line and "may continue past it" in line


def test_profile_limit_edge_says_the_search_cannot_go_past_it():
    (hit,) = edge_hits([1.0, 2.0, 1.0], BOX, NAMES, limits=LIMITS)
    assert (hit.name, hit.side, hit.at_limit) == ("PSC_VELXY_I", "upper", True)
    assert "profile's upper limit" in hit.message() and "[[gains]] max" in hit.message()


def test_lower_edges_and_tolerance():
    width = BOX[:, 1] - BOX[:, 0]
    inside = BOX[:, 0] + (TOL * 1.01) * width  # just past the tolerance: no hit
    assert edge_hits(inside, BOX, NAMES) == []
    at = BOX[:, 0] + (TOL * 0.99) * width
    hits = edge_hits(at, BOX, NAMES, limits=LIMITS)
    assert [(h.name, h.side) for h in hits] == [(n, "lower") for n in NAMES]
    assert [h.at_limit for h in hits] == [True, True, False]  # 0.5 of VELXY_I is the trust region, not the 0.1 limit


def test_gain_switched_off_at_a_zero_limit_and_zero_width_boxes_are_no_cap():
    box = np.array([[0.0, 0.5], [0.3, 0.3]])
    assert edge_hits([0.0, 0.3], box, ["POS_X_I", "FIXED"], limits=np.array([[0.0, 0.5], [0.0, 1.0]])) == []
    # Without the profile's limits a zero lower edge might be the trust region's: it is reported.
    assert [h.side for h in edge_hits([0.0, 0.3], box, ["POS_X_I", "FIXED"])] == ["lower"]


def test_near_best_points_on_the_same_edge_are_counted():
    near = np.array([[1.75, 2.0, 0.8], [1.74, 3.0, 0.7], [1.2, 2.0, 0.8]])
    (hit,) = edge_hits([1.75, 2.0, 0.8], BOX, NAMES, limits=LIMITS, near_best=near)
    assert (hit.near_best, hit.n_near) == (2, 3)
    assert "2 of the 3 best flights sit on this edge too" in hit.message()


def test_shape_mismatch_is_refused():
    with pytest.raises(ValueError, match="gains"):
        edge_hits([1.0, 2.0], BOX, NAMES)


@given(st.lists(st.floats(0.0, 1.0), min_size=3, max_size=3))
def test_a_hit_exactly_when_within_the_tolerance_of_an_edge(u):
    assume(all(abs(v - TOL) > 1e-9 and abs(v - (1 - TOL)) > 1e-9 for v in u))  # rounding at the threshold itself
    x = BOX[:, 0] + np.asarray(u) * (BOX[:, 1] - BOX[:, 0])
    hits = edge_hits(x, BOX, NAMES)
    expected = [(n, "lower") for n, v in zip(NAMES, u) if v <= TOL] + [(n, "upper") for n, v in zip(NAMES, u)
                                                                        if v >= 1 - TOL]
    assert sorted((h.name, h.side) for h in hits) == sorted(expected)
    assert len(edge_lines(hits)) == len(hits)
    assert all(isinstance(h, EdgeHit) and h.bound in BOX[NAMES.index(h.name)] for h in hits)


@pytest.mark.timeout(120)
@pytest.mark.parametrize("upper, at_edge", [(0.25, True), (0.6, False)])
def test_safe_bo_ends_on_the_edge_of_a_box_that_excludes_the_optimum(upper, at_edge):
    """The planar simulator with only POS_X_P tuned (the rest at the profile defaults): P rises from 0.19 at the
    default 0.15 to about 0.43 near 0.4 and falls beyond (measured, 3 episodes each). A box ending at 0.25 excludes
    that optimum: the recommendation ends on the edge and the note says the improvement may continue; a box to 0.6
    contains it: no note."""
    from ksbo_mav import optimize
    from ksbo_mav.simulated.planar_objective import SimObjective
    from ksbo_mav.profiles import load_profile

    profile = load_profile("sim-planar")
    obj = SimObjective(profile, seed=0)
    base = profile.default.copy()

    def fly(x):
        gains = base.copy()
        gains[0] = x[0]
        return obj(gains)

    box = np.array([[0.1, upper]])
    result = optimize(fly, [0.15], box, budget=25, method="ksbo", seed=0)
    lines = edge_lines(edge_hits(result.x, box, ["POS_X_P"], limits=profile.bounds[:1]))
    if at_edge:
        assert lines == [f"POS_X_P = {result.x[0]:.4g} is at the upper bound 0.25 of the search box (it grows from "
                         "the baseline's trust region; the profile allows 1): the improvement may continue past it; "
                         "accept these gains and tune again from them (the first box is centred on the vehicle's "
                         "gains), or fly a longer campaign (--budget)"]
    else:
        assert lines == [] and 0.25 < result.x[0] < 0.6
