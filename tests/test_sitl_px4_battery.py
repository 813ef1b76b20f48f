"""A real PX4 SITL (SIH quad) with its default simulated pack: it drains 100 % per SIM_BAT_DRAIN (60 s) down to
SIM_BAT_MIN_PCT (50 %), so the first trial uses about 40 % and the battery watch rightly refuses the next one. The
stop must say that this is the simulator's pack and name the setting that makes it last, not only "swap the
battery"; and the tool recognises the simulator from its parameter table.

The test (not the tool) sets COM_RCL_EXCEPT = 4 (OFFBOARD without RC), as a bench without RC needs."""

from __future__ import annotations

import pytest

from sitl_helpers import endpoint, tool

# slow: a campaign until the default pack runs down (~33 s); the battery stop itself is in the default run on our
# simulator (test_battery_campaign)
pytestmark = [pytest.mark.sitl, pytest.mark.slow, pytest.mark.network, pytest.mark.timeout(600)]


def test_the_default_px4_sitl_pack_stops_the_campaign_with_the_setting_that_makes_it_last(tmp_path):
    from conftest import sitl_or_skip

    from ksbo_mav.mav.simulator import simulator_of
    from ksbo_mav.mav.vehicle import Vehicle

    # PX4's own defaults (no longer-lasting pack set for the test); 5x: one trial is all it needs
    sitl = sitl_or_skip("px4", 5, keep_params=True)
    try:
        assert sitl.set_param("COM_RCL_EXCEPT", 4, int32=True) == 4
        v = Vehicle.connect(endpoint(sitl), "px4-copter", sysid=250, compid=190)
        try:
            table = {n: p.value for n, p in v.params.table.items()}
        finally:
            v.close()
        assert simulator_of(table) == "PX4 SITL" and table["SIM_BAT_DRAIN"] == 60.0
        d = tmp_path / "camp"
        r = tool("tune", str(d), *sitl.cli_args, "--prior", "none", "--budget", "3")
        assert r.returncode == 3, r.stderr[-3000:]  # a normal stop: the battery watch, after the first trial
        last = r.stderr.strip().splitlines()[-1]
        assert last.startswith("stopped: battery: ") and "a trial uses up to" in last, last
        assert "this is PX4 SITL's simulated pack" in last and "SIM_BAT_DRAIN = 60 s" in last, last
        assert "set SIM_BAT_DRAIN to 3600" in last and "`ksbo-mav tune --resume" in last, last
        assert "landed and disarmed" in r.stderr
        print(last)  # the stop as the user reads it, for the record
    finally:
        sitl.stop()
