"""The onboard guard's protocol against the built-in simulator's simulated guard: the same installer, trial arming
and removal the tuner runs on ArduPilot, and the guard's answers to a cut link and a pilot's mode change, watched
on a second connection while the tuner stand-in (a process of its own) is killed. The simulator runs in real time
so the stand-in's heartbeats keep the pace they have on a vehicle. Then whole campaigns (``ksbo-mav tune`` on the
lockstep simulator): the guard installed and removed without a trace, and a vehicle without scripting refused
unless told to fly without the guard."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from guard_helpers import Observer, assert_baseline, start_tuner, stop
from mav_tune_helpers import sim_and_endpoint

from ksbo_mav.mav.guard_script import GUARD_PARAMS, GuardState, config_for, new_config_id
from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.monitor import limits_from_profile
from ksbo_mav.mav.onboard_guard import GuardUnavailable, OnboardGuard
from ksbo_mav.mav.vehicle import Vehicle
from ksbo_sim.process import SimProcess

pytestmark = [pytest.mark.network, pytest.mark.timeout(120)]

PROFILE = "sim-planar"
LOITER = 5
TRIAL = {"POS_X_P": 0.2, "POS_Z_P": 0.2}


@pytest.fixture()
def sim():
    with SimProcess("--speedup", "1") as s:
        yield s


def device(sim) -> str:
    return f"udpout:{sim.host}:{sim.port}"


@pytest.mark.slow  # default run: the same link cut in both parameter generations, in this module
def test_link_cut_restores_baseline_and_holds(sim):
    proc, values = start_tuner(device(sim), PROFILE, {"trial": TRIAL})
    obs = Observer(device(sim))
    try:
        armed_ms = obs.armed_at()
        assert obs.param("POS_X_P") == pytest.approx(0.2)  # the trial gains are flying
        stop(proc)
        assert obs.until(lambda: obs.first_alive(GuardState.TRIPPED, armed_ms) is not None, 20.0), obs.texts
        assert obs.param("KSG_TRIP") == 1
        assert_baseline(obs, values["baseline"])
        assert obs.until(lambda: obs.mode == LOITER, 5.0)
        assert any("link lost" in t for t in obs.texts), obs.texts
    finally:
        stop(proc)
        obs.close()


@pytest.mark.slow
def test_pilot_mode_change_restores_baseline_and_keeps_the_pilots_mode(sim):
    proc, values = start_tuner(device(sim), PROFILE, {"trial": TRIAL})
    obs = Observer(device(sim))
    try:
        armed_ms = obs.armed_at()
        obs.set_mode(LOITER)
        assert obs.until(lambda: obs.first_alive(GuardState.TRIPPED, armed_ms) is not None, 20.0), obs.texts
        assert obs.param("KSG_TRIP") == 4
        assert_baseline(obs, values["baseline"])
        assert any("pilot mode change" in t for t in obs.texts), obs.texts
    finally:
        stop(proc)
        obs.close()


def _connect(sim) -> Vehicle:
    return Vehicle.connect(Endpoint("udpout", sim.host, sim.port), PROFILE)


def test_install_arm_disarm_remove(sim):
    v = _connect(sim)
    try:
        baseline = {name: v.params.read(name) for name in v.gain_map.param_names}
        guard = OnboardGuard(v.link, v.params, v.cmd)
        with pytest.raises(GuardUnavailable, match="not answering"):
            guard.arm_trial()  # nothing installed: the tuner refuses to fly
        guard.install(config_for(limits_from_profile(v.profile), 3.0, baseline, new_config_id()))
        assert v.params.read("MAV_GCS_SYSID") == v.link.mav.srcSystem
        with pytest.raises(GuardUnavailable, match="disarmed"):
            guard.arm_trial()  # on the ground: the guard refuses and says why
        v.setup_streams()
        v.ensure_airborne()
        guard.arm_trial()
        assert guard.disarm_trial() == GuardState.ARMED  # ended by the tuner, never tripped
        guard.remove()
        for name, default in GUARD_PARAMS.items():
            assert v.params.read(name) == default
        assert v.params.read("MAV_GCS_SYSID") == 255
        v.link.pump(1.0)
        guard.alive_wall = 0.0
        v.link.pump(1.5)
        assert guard.alive_wall == 0.0  # the scripts restarted without the guard
    finally:
        v.close()


def test_a_guard_that_never_reports_is_taken_back_off_the_vehicle(monkeypatch):
    """An install that fails after it claimed the GCS system id and uploaded the script puts both back before it
    raises: the campaign never learns of this guard, so nothing else would. Made to happen as on a vehicle whose
    SCR_ENABLE was set without the reboot it needs: the scripts do not run (here SCR_ENABLE 0 with the installer's
    check skipped)."""
    import ksbo_mav.mav.onboard_guard as onboard_guard
    from ksbo_mav.mav.ftp_files import list_dir

    monkeypatch.setattr(onboard_guard, "ALIVE_WAIT_S", 2.0)
    with SimProcess("--speedup", "1", "--set", "SCR_ENABLE=0") as s:
        v = _connect(s)
        try:
            baseline = {name: v.params.read(name) for name in v.gain_map.param_names}
            guard = OnboardGuard(v.link, v.params, v.cmd)
            guard.check_scripting = lambda: None
            with pytest.raises(GuardUnavailable, match="did not report"):
                guard.install(config_for(limits_from_profile(v.profile), 3.0, baseline, new_config_id()))
            assert guard.gcs_sysid_param == "MAV_GCS_SYSID"  # it had been claimed
            assert v.params.read("MAV_GCS_SYSID") == 255
            assert "ksbo_guard.lua" not in (list_dir(v.link, "scripts") or [])
        finally:
            v.close()


def test_vehicle_without_scripting_is_refused_in_one_line():
    with SimProcess("--set", "SCR_ENABLE=0") as s:
        v = _connect(s)
        try:
            with pytest.raises(GuardUnavailable, match="set SCR_ENABLE to 1 and reboot"):
                OnboardGuard(v.link, v.params, v.cmd).check_scripting()
        finally:
            v.close()


def _tune(endpoint, d, *extra: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), "--udp",
                           f"{endpoint.host}:{endpoint.port}", "--prior", "none", "--budget", "2", "--confirm", "0",
                           *extra], capture_output=True, text=True, timeout=300, env=dict(os.environ, MAVLINK20="1"))


def test_a_campaign_without_scripting_flies_nothing_unless_told_to_fly_without_the_guard(tmp_path):
    with sim_and_endpoint("--set", "SCR_ENABLE=0") as (_, endpoint):
        r = _tune(endpoint, tmp_path / "refused")  # the guard is the default
        assert r.returncode != 0
        last = r.stderr.strip().splitlines()[-1]  # one line says what to set
        assert last.startswith("error: ") and "set SCR_ENABLE to 1 and reboot" in last, r.stderr[-2000:]
        assert "--no-onboard-guard" in last
        assert "Traceback" not in r.stderr
        assert not list((tmp_path / "refused").glob("trials/trial_*.json"))
        r = _tune(endpoint, tmp_path / "without", "--no-onboard-guard")
        assert r.returncode == 0, r.stderr[-2000:]
        assert "WITHOUT the onboard guard" in r.stdout + r.stderr
        assert "WITHOUT the onboard guard" in (tmp_path / "without" / "report" / "index.html").read_text()


@pytest.mark.slow  # default run: the guard installed and removed on SITL: test_sitl_guard, test_sitl_ardupilot
def test_a_campaign_installs_the_guard_and_leaves_no_trace_of_it(tmp_path):
    with sim_and_endpoint() as (sim, endpoint):
        r = _tune(endpoint, tmp_path / "c")  # the guard is the default
        assert r.returncode == 0, r.stderr[-2000:]
        out = r.stdout + r.stderr
        assert "onboard guard: running" in out and "onboard guard: removed" in out
        v = _connect(sim)
        try:
            assert v.params.read("KSG_STATE") == 0 and v.params.read("MAV_GCS_SYSID") == 255
        finally:
            v.close()


@pytest.mark.parametrize(("personality", "gcs_sysid", "gain"), [
    ("ardupilot", "MAV_GCS_SYSID", "PSC_NE_POS_P"),  # ArduCopter 4.7
    ("ardupilot-legacy", "SYSID_MYGCS", "PSC_POSXY_P"),  # ArduCopter 4.5 / 4.6
])
def test_both_ardupilot_generations_link_cut_restores_baseline(personality, gcs_sysid, gain):
    """The guard's protocol on each ArduPilot generation of the JSBSim copter: installed with the generation's
    ground-station id parameter set to the tuner, armed over a trial of that generation's gain names, tripped by a
    cut link, the baseline back and the vehicle holding."""
    with SimProcess("--speedup", "1", "--vehicle", "copter3d", "--personality", personality,
                    "--set", "TKOFF_SPEED=3") as s:
        proc, values = start_tuner(device(s), "ardupilot-copter", {"trial": {gain: 1.5}})
        obs = Observer(device(s))
        try:
            armed_ms = obs.armed_at()
            assert obs.param(gain) == pytest.approx(1.5)
            assert obs.param(gcs_sysid) != 255  # the tuner's own system id while the campaign runs
            stop(proc)
            assert obs.until(lambda: obs.first_alive(GuardState.TRIPPED, armed_ms) is not None, 20.0), obs.texts
            assert obs.param("KSG_TRIP") == 1
            assert_baseline(obs, values["baseline"])
            assert obs.until(lambda: obs.mode == LOITER, 5.0)
        finally:
            stop(proc)
            obs.close()
