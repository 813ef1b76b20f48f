"""PX4 main (v1.19.0-dev, ../shared/sitl/px4-main) in the default run: what differs from v1.15.4. The firmware line
and the parameter generation (MAN_OVERRIDE_SPD, no COM_RC_OVERRIDE), the parameters by the PARAM protocol (no
``@PARAM/param.pck`` in this commit), the stick override and the SIH drag in the plan; SIH's wind blowing from where
its vector points (the vehicle leans into it); a campaign from the ground with the firmware in its report
(slow). The rest of the PX4 tests fly main with ``KSBO_PX4_BUILD=main pytest -m sitl``.

The test (not the tool) sets COM_RCL_EXCEPT = 4 (OFFBOARD without RC), as a user with no RC would."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from sitl_helpers import counted_trials, endpoint, param_diff, read_all, short_campaign, tool

pytestmark = [pytest.mark.sitl, pytest.mark.network, pytest.mark.timeout(600)]
FIRMWARE = ("firmware: PX4 1.19.0-dev (AUTOPILOT_VERSION), parameter generation 1.18+ (MAN_OVERRIDE_SPD, no "
            "COM_RC_OVERRIDE), verified: flown on SITL here (docs/firmware.md, row px4 1.19.0-dev any)")


@pytest.fixture(scope="module")
def sitl(px4_main_sitl):
    assert px4_main_sitl.set_param("COM_RCL_EXCEPT", 4, int32=True) == 4
    return px4_main_sitl


def test_px4_main_says_its_firmware_generation_and_wind_plan(sitl, tmp_path):
    r = tool("tune", str(tmp_path / "c"), *sitl.cli_args, "--dry-run", "--wind", "5")
    said = " ".join((r.stdout + r.stderr).split())
    assert r.returncode == 0, r.stderr[-2000:]
    assert said.count(FIRMWARE) == 2  # at connect and in the plan
    assert "(PARAM protocol" in said or "(cache" in said
    assert "MAN_OVERRIDE_SPD" in said and "COM_RC_OVERRIDE" not in said.replace("no COM_RC_OVERRIDE", "")
    # SIH's own drag (SIH_KDV / SIH_MASS): 5 m/s is past the profile's 40 deg at full size
    assert "the simulator's SIH_KDV / SIH_MASS = 1 1/s" in said and "MPC_TILTMAX_AIR 45 deg less 3" in said


def _thrust_direction(att) -> np.ndarray:
    """Unit north-east direction of the thrust's horizontal part (the body's up axis) from ATTITUDE."""
    cr, sr, sp = math.cos(att.roll), math.sin(att.roll), math.sin(att.pitch)
    cy, sy = math.cos(att.yaw), math.sin(att.yaw)
    up = -np.array([cy * sp * cr + sy * sr, sy * sp * cr - cy * sr])
    return up / np.linalg.norm(up)


@pytest.mark.slow  # default run: the wind-campaigns benchmark checks the sign before writing a number
@pytest.mark.solo  # OFFBOARD at 5x: the tuner needs the two cores beside the SITL
def test_sih_wind_blows_from_where_its_vector_points(sitl):
    """SIH_WIND_N = SIH_WIND_E = 3.54 (5 m/s): holding position, the vehicle leans into the north-east, the wind
    comes from there (SIH flies v_apparent = v + wind)."""
    from ksbo_mav.mav.vehicle import Vehicle

    sitl.set_param("SIH_WIND_N", 3.54)
    sitl.set_param("SIH_WIND_E", 3.54)
    v = Vehicle.connect(endpoint(sitl), "px4-copter")
    try:
        v.setup_streams()
        v.ensure_airborne()
        seen, t0 = [], time.monotonic()
        while time.monotonic() - t0 < 4.0:
            v.link.pump(0.05)
            if v.telemetry.last_att is not None:
                seen.append(_thrust_direction(v.telemetry.last_att))
        lean = np.mean(seen, axis=0)
        bearing = math.degrees(math.atan2(lean[1], lean[0])) % 360
        assert 20 < bearing < 70, bearing  # into the north-east
        v.land()
    finally:
        v.close()
        sitl.set_param("SIH_WIND_N", 0.0)
        sitl.set_param("SIH_WIND_E", 0.0)


@pytest.mark.slow  # the campaign path is PX4 1.15's default-run proof; this build's differences are proven above
def test_px4_main_campaign_from_the_ground(sitl, tmp_path):
    d, summary, log = short_campaign(sitl, tmp_path / "camp")
    assert "arming and taking off to 10 m" in log and "landed and disarmed" in log
    recs = counted_trials(d)  # (a trial a loaded machine spoiled is flown again)
    assert len(recs) == 3 and all(r["outcome"] == "ok" for r in recs)
    assert "1.19.0-dev" in (d / "report" / "index.html").read_text()
    now, armed = read_all(sitl, "px4-copter")
    assert not armed
    diff = param_diff(d, now)
    assert not diff, diff
