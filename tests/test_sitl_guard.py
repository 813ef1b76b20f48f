"""The onboard guard on a real ArduCopter SITL with Lua scripting: it restores the baseline gains and stops the
vehicle itself when the tuner's link dies mid-trial, when the box is left, and (gains only) when a pilot takes
over; and it goes away without a trace.

The tuner is a process of its own (``guard_trial_process.py``) holding SERIAL0; the test watches the vehicle on a
second MAVLink connection (SERIAL1, 5762+10N) that the tuner does not use, and measures on the vehicle's clock:
the cut is the last vehicle timestamp seen before the tuner was killed, the restore is the timestamp of the
guard's ``KSG_ALIVE`` = tripped, sent in the same script tick that wrote the gains back.
"""

from __future__ import annotations

import pytest
from conftest import sitl_or_skip
from guard_helpers import Observer, assert_baseline, start_tuner, stop
from ksbo_sim.sitl_instances import release_stopped

from ksbo_mav.mav.guard_script import (
    GUARD_PARAMS,
    SCRIPT_NAME,
    GuardState,
    config_for,
    new_config_id,
)
from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.monitor import limits_from_profile
from ksbo_mav.mav.onboard_guard import OnboardGuard
from ksbo_mav.mav.vehicle import Vehicle

pytestmark = [pytest.mark.sitl, pytest.mark.network, pytest.mark.timeout(600)]

#: Slow enough that the tuner stand-in's heartbeats (every 1/6 of the link timeout, in vehicle time) keep up on a
#: busy 2-core machine; the guard counts on the vehicle's clock, so the speed-up changes no vehicle-time figure.
SPEEDUP = 3
BRAKE, LOITER = 17, 5
PROFILE = "ardupilot-copter"


@pytest.fixture(scope="module")
def scripting_sitl():
    """ArduCopter SITL booted with SCR_ENABLE 1 (the setting takes effect at boot, as on a flight controller; the
    guard's installer refuses a vehicle without it)."""
    sitl = sitl_or_skip("ardupilot", SPEEDUP)
    yield sitl
    sitl.stop()
    release_stopped()


TRIAL = {"PSC_POSXY_P": 1.8, "PSC_VELXY_P": 3.2}


def test_link_cut_restores_baseline_and_stops_on_board(scripting_sitl):
    obs = Observer(f"tcp:127.0.0.1:{scripting_sitl.tcp_ports[1]}")
    proc, values = start_tuner(f"tcp:127.0.0.1:{scripting_sitl.tcp_port}", PROFILE, {"trial": TRIAL})
    try:
        obs.pump(1.0)
        assert obs.param("PSC_POSXY_P") == pytest.approx(1.8)  # the trial gains are flying
        cut_ms = obs.vehicle_ms  # the last vehicle time seen while the tuner still held the link
        stop(proc)
        assert obs.until(lambda: obs.first_alive(GuardState.TRIPPED, cut_ms) is not None, 60.0), obs.texts
        restored_ms = obs.first_alive(GuardState.TRIPPED, cut_ms)
        assert_baseline(obs, values["baseline"])
        assert obs.until(lambda: obs.mode in (BRAKE, LOITER), 5.0), obs.texts  # the next heartbeat shows it
        assert obs.param("KSG_TRIP") == 1
        assert any("link lost" in t for t in obs.texts), obs.texts
        timeout_ms = 3000  # the profile's heartbeat_timeout_s
        print(f"link cut at vehicle {cut_ms} ms, baseline back and BRAKE at {restored_ms} ms: "
              f"{restored_ms - cut_ms} ms (limit {timeout_ms + 1000} ms); guard said {obs.texts}")
        assert restored_ms - cut_ms <= timeout_ms + 1000
        assert obs.until(lambda: obs.mode == LOITER, 30.0)  # BRAKE, then the safe mode
    finally:
        stop(proc)
        obs.land()
        obs.close()


@pytest.mark.slow
def test_box_left_restores_baseline_and_brakes(scripting_sitl):
    obs = Observer(f"tcp:127.0.0.1:{scripting_sitl.tcp_ports[1]}")
    # The figure-8 starts at the origin's north 0: a 3 m box, and the trial flown 6 m north.
    spec = {"trial": TRIAL, "limits": {"x_max_m": 3.0}, "fly_to": [6.0, 0.0, -10.0]}
    proc, values = start_tuner(f"tcp:127.0.0.1:{scripting_sitl.tcp_port}", PROFILE, spec)
    try:
        armed_ms = obs.armed_at()
        assert obs.until(lambda: obs.first_alive(GuardState.TRIPPED, armed_ms) is not None, 60.0), obs.texts
        assert obs.param("KSG_TRIP") == 2
        assert_baseline(obs, values["baseline"])
        assert obs.until(lambda: obs.mode in (BRAKE, LOITER), 5.0)
        assert any("north" in t for t in obs.texts), obs.texts
    finally:
        stop(proc)
        obs.land()
        obs.close()


@pytest.mark.slow  # default run: a pilot's take-over: test_pilot_takeover, test_guard_trip
def test_pilot_mode_change_restores_baseline_and_keeps_the_pilots_mode(scripting_sitl):
    obs = Observer(f"tcp:127.0.0.1:{scripting_sitl.tcp_ports[1]}")
    proc, values = start_tuner(f"tcp:127.0.0.1:{scripting_sitl.tcp_port}", PROFILE, {"trial": TRIAL})
    try:
        armed_ms = obs.armed_at()
        obs.set_mode(LOITER)  # the pilot (a ground station on another link) takes over
        assert obs.until(lambda: obs.first_alive(GuardState.TRIPPED, armed_ms) is not None, 30.0), obs.texts
        assert obs.param("KSG_TRIP") == 4
        assert_baseline(obs, values["baseline"])
        obs.pump(3.0)  # the guard leaves the pilot's mode alone (no BRAKE)
        assert obs.mode == LOITER
    finally:
        stop(proc)
        obs.land()
        obs.close()


def test_install_then_removal_leaves_no_script_and_default_parameters(scripting_sitl):
    v = Vehicle.connect(Endpoint("tcp", "127.0.0.1", scripting_sitl.tcp_port), "ardupilot-copter")
    try:
        gcs_sysid = v.params.read("MAV_GCS_SYSID")
        baseline = {name: v.params.read(name) for name in v.gain_map.param_names}
        guard = OnboardGuard(v.link, v.params, v.cmd)
        guard.install(config_for(limits_from_profile(v.profile), 3.0, baseline, new_config_id()))
        assert guard.answering() and v.params.read("MAV_GCS_SYSID") == v.link.mav.srcSystem
        guard.remove()
        for name, default in GUARD_PARAMS.items():
            assert v.params.read(name) == default
        assert v.params.read("MAV_GCS_SYSID") == gcs_sysid
        v.link.pump(1.0)
        guard.alive_wall = 0.0
        v.link.pump(3.0)
        assert guard.alive_wall == 0.0  # no KSG_ALIVE since the scripts restarted without it
    finally:
        v.close()
    assert not (scripting_sitl.workdir / "scripts" / SCRIPT_NAME).exists()
