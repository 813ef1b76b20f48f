"""Our JSBSim copter fitted to a vehicle's parameter set: real sets downloaded from ArduCopter SITL (legacy PSC_*
names) and PX4 SITL (tests/data), and the fallbacks when a vehicle does not report what the fit takes."""

from __future__ import annotations

from pathlib import Path

import pytest

from ksbo_mav.simulated.vehicle_fit import fit_vehicle

DATA = Path(__file__).parent / "data"


def read_params(name: str) -> dict[str, float]:
    """{name: value} of a QGroundControl .params file (Vehicle-Id, Component-Id, Name, Value, Type)."""
    rows = [line.split("\t") for line in (DATA / name).read_text().splitlines() if line and not line.startswith("#")]
    return {r[2]: float(r[3]) for r in rows}


def test_arducopter_sitl_set_legacy_names_converted_and_hover_taken() -> None:
    params = read_params("arducopter-sitl.params")
    assert "PSC_POSXY_P" in params and "PSC_NE_POS_P" not in params  # the <= 4.7.0-dev generation
    fit = fit_vehicle(params, "ardupilot")
    sim = fit.sim_params
    assert fit.personality == "ardupilot"
    assert fit.hover == pytest.approx(params["MOT_THST_HOVER"]) and fit.hover_source == "MOT_THST_HOVER"
    assert sim["MOT_THST_HOVER"] == pytest.approx(0.39, abs=1e-6)
    assert (fit.frame, fit.motors, fit.frame_matches) == ("quad", 4, True)
    assert fit.mass_kg is None
    # Units that changed between generations: IMAX cm/s^2 -> m/s^2, ACCZ P/I per 10 m/s^2 -> per m/s^2.
    assert sim["PSC_NE_VEL_IMAX"] == pytest.approx(params["PSC_VELXY_IMAX"] * 0.01)
    assert sim["PSC_D_ACC_P"] == pytest.approx(params["PSC_ACCZ_P"] * 0.1)
    assert sim["PSC_D_ACC_IMAX"] == pytest.approx(params["PSC_ACCZ_IMAX"] * 0.001)
    # The attitude and rate loops and the lean limit are the vehicle's own values.
    for name in ("ATC_RAT_RLL_P", "ATC_RAT_YAW_P", "ATC_ANG_PIT_P", "ATC_INPUT_TC", "ANGLE_MAX"):
        assert sim[name] == params[name]
    assert sim["ATC_RAT_YAW_P"] == pytest.approx(0.3)  # differs from our copter's default 0.18
    # Simulator settings and the geofence are not the vehicle's to give.
    assert not [n for n in sim if n.startswith(("SIM_", "FENCE_"))]
    assert "ARMING_CHECK" not in sim
    assert "MOT_THST_HOVER 0.39" not in fit.describe() and "hover thrust 0.39 (MOT_THST_HOVER)" in fit.describe()


def test_px4_sitl_set_hover_rate_loops_limits_and_the_simulators_mass() -> None:
    params = read_params("px4-sitl.params")
    fit = fit_vehicle(params, "px4")
    sim = fit.sim_params
    assert fit.personality == "px4"
    assert (fit.hover, fit.hover_source) == (pytest.approx(0.5), "MPC_THR_HOVER")
    assert (fit.frame, fit.motors) == ("quad", 4)
    assert fit.mass_kg == pytest.approx(params["SIH_MASS"])
    for name in ("MC_ROLLRATE_P", "MC_ROLLRATE_K", "MC_PITCH_P", "MPC_TILTMAX_AIR", "MPC_XY_VEL_MAX"):
        assert sim[name] == params[name]
    assert not [n for n in sim if n.startswith(("GF_", "SIM_"))]
    assert "SYS_AUTOSTART" not in sim and "MPC_POS_MODE" not in sim
    assert "mass 1 kg (not used)" in fit.describe()


def test_missing_and_unusable_parameters_fall_back_and_say_so() -> None:
    empty = fit_vehicle({}, "px4")
    assert empty.hover is None and empty.sim_params == {} and empty.motors is None and empty.frame_matches
    assert "MPC_THR_HOVER not reported" in empty.describe() and "0.22" in empty.describe()
    assert "; frame not reported; 0 loop gains and limits; mass not reported" in empty.describe()
    odd = fit_vehicle({"MOT_THST_HOVER": 0.0, "FRAME_CLASS": 2, "ATC_INPUT_TC": float("nan")}, "ardupilot")
    assert odd.hover is None and "MOT_THST_HOVER 0 out of 0.05..0.95, not used" in odd.describe()
    assert "MOT_THST_HOVER" not in odd.sim_params and "ATC_INPUT_TC" not in odd.sim_params
    assert (odd.frame, odd.motors, odd.frame_matches) == ("hexa", 6, False)
    assert "hexa, 6 motors (simulated as a quad)" in odd.describe()
    assert fit_vehicle({"FRAME_CLASS": 99}, "ardupilot").frame == "FRAME_CLASS 99"
    with pytest.raises(ValueError, match="no simulated copter for the 'planar' stack"):
        fit_vehicle({}, "planar")
