"""The day's wind before takeoff (``tune --wind``): the figure-8's predicted lean, and the way forward past the tilt
limit (the vehicle's own limit less a margin, else the figure-8 scaled down, else a one-line refusal), said in the
plan of a dry run against our simulator."""

from __future__ import annotations

import subprocess
import sys

import pytest
from mav_tune_helpers import sim_and_endpoint

from ksbo_mav.campaign.wind_preflight import (HEADROOM_DEG, MARGIN_DEG, Drag, own_tilt_limit, peak_lean_deg,
                                              plan_for_wind, vehicle_drag)
from ksbo_mav.errors import InputError
from ksbo_task.figure8_ne import Figure8H

F8 = Figure8H(lead_in=5.0)  # the copter profiles' figure-8
SIH = {"SIH_KDV": 1.0, "SIH_MASS": 1.0, "MPC_TILTMAX_AIR": 45.0}


def test_the_lean_grows_with_the_wind_and_shrinks_with_the_pattern():
    drag = Drag(1.0, 0.0, "test")
    calm, windy = peak_lean_deg(F8, 0.0, drag), peak_lean_deg(F8, 5.0, drag)
    assert calm < windy
    # no drag, no wind: the pattern's own acceleration (about 1 m/s^2 at its peaks: fact sheet 8)
    assert peak_lean_deg(F8, 0.0, Drag(0.0, 0.0, "none")) == pytest.approx(6.0, abs=1.5)
    smaller = Figure8H(amp_north=8.0, amp_east=2.0, lead_in=5.0)
    assert peak_lean_deg(smaller, 5.0, drag) < windy


def test_drag_and_own_limit_come_from_the_vehicle():
    assert vehicle_drag(SIH).c_lin == 1.0 and "SIH_KDV" in vehicle_drag(SIH).source
    fusion = vehicle_drag({"EKF2_DRAG_CTRL": 1, "EKF2_MCOEF": 0.2, "EKF2_BCOEF_X": 50.0})
    assert fusion.c_lin == 0.2 and fusion.c_quad > 0
    assert "guess" in vehicle_drag({}).source
    assert own_tilt_limit("px4", SIH) == (45.0, "MPC_TILTMAX_AIR")
    assert own_tilt_limit("ardupilot", {"PSC_ANGLE_MAX": 0.0, "ANGLE_MAX": 3000}) == (30.0, "ANGLE_MAX")
    assert own_tilt_limit("ardupilot", {"PSC_ANGLE_MAX": 25.0, "ANGLE_MAX": 3000}) == (25.0, "PSC_ANGLE_MAX")


def test_calm_air_changes_nothing():
    wp = plan_for_wind(0.0, F8, 40.0, "px4", SIH)
    assert (wp.tilt_max_deg, wp.scale) == (40.0, 1.0) and "fits" in wp.text


def test_the_limit_is_raised_to_the_vehicles_own_less_a_margin():
    wind = 4.0
    peak = peak_lean_deg(F8, wind, vehicle_drag(SIH))
    limit = peak + HEADROOM_DEG - 1.0  # just too tight for this wind
    wp = plan_for_wind(wind, F8, limit, "px4", SIH)
    assert wp.tilt_max_deg == 45.0 - MARGIN_DEG and wp.scale == 1.0
    assert "MPC_TILTMAX_AIR" in wp.text and "raised" in wp.text


def test_the_figure8_is_scaled_when_the_raised_limit_is_not_enough():
    wp = plan_for_wind(5.0, F8, 40.0, "px4", SIH)  # SIH's drag 1/s: 5 m/s needs ~42 deg at full size
    assert wp.scale < 1.0 and wp.tilt_max_deg == 42.0
    scaled = Figure8H(amp_north=10.0 * wp.scale, amp_east=2.5 * wp.scale, lead_in=5.0)
    assert peak_lean_deg(scaled, 5.0, vehicle_drag(SIH)) + HEADROOM_DEG <= wp.tilt_max_deg
    assert "scaled" in wp.text


def test_too_much_wind_is_refused_in_one_line():
    with pytest.raises(InputError, match="fly in less wind") as e:
        plan_for_wind(9.0, F8, 40.0, "px4", SIH)
    assert "\n" not in str(e.value)


@pytest.mark.network
def test_the_plan_says_the_wind_decision(tmp_path):
    with sim_and_endpoint("--vehicle", "copter3d", "--personality", "px4") as (_sim, ep):
        r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(tmp_path / "c"), "--udp",
                            f"{ep.host}:{ep.port}", "--dry-run", "--wind", "30"], capture_output=True, text=True,
                           timeout=120)
    out = " ".join((r.stdout + r.stderr).split())
    assert r.returncode != 0 and "fly in less wind" in out and "Traceback" not in out
    with sim_and_endpoint("--vehicle", "copter3d", "--personality", "px4") as (_sim, ep):
        r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(tmp_path / "c"), "--udp",
                            f"{ep.host}:{ep.port}", "--dry-run", "--wind", "5"], capture_output=True, text=True,
                           timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    out = " ".join((r.stdout + r.stderr).split())
    assert out.count("wind 5 m/s (declared): the figure-8 needs up to") == 2  # at connect and in the plan
