"""The onboard guard's own stop is the gains' abort, not a pilot's take-over; and validation flights fly guarded.

The built-in simulator's simulated guard (the JSBSim copter with ArduPilot's names, lockstep) is installed with a
box or tilt limit tighter than the tuner's monitor, so that the guard, not the monitor, finds the breach and
switches the vehicle to its hold mode: the tuner records the trial as aborted by the gains with the guard's
reason, takes the vehicle back to GUIDED, and flies on. A validation flight arms the guard with its own modes
declared (LOITER for the hold): the guard lets the hold fly, trips for a pilot's other mode, and stops a tilt; a
whole campaign (marked slow) flies its validation flights guarded.
The same on ArduCopter SITL with the Lua script: ``test_sitl_guard_trip.py``.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from onboard_helpers import short_mission

from ksbo_mav.mav.guard_script import MODES_PARAM, STATE_PARAM, config_for, figure8_for, modes_mask, new_config_id
from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.monitor import Monitor, limits_from_profile
from ksbo_mav.mav.objective import MavlinkObjective
from ksbo_mav.mav.onboard_guard import OnboardGuard
from ksbo_mav.mav.outcome import TrialOutcome as T
from ksbo_mav.mav.validation import ManoeuvreSpec, fly_manoeuvre
from ksbo_mav.mav.vehicle import Vehicle
from ksbo_mav.errors import InputError
from ksbo_sim.process import SimProcess

pytestmark = [pytest.mark.network, pytest.mark.timeout(240)]

PROFILE = "ardupilot-copter"
LOITER, STABILIZE = 5, 0


def test_the_modes_mask_has_a_bit_per_declared_mode():
    assert modes_mask([]) == 0.0 and modes_mask([5]) == 32.0 and modes_mask([3, 5, 5]) == 40.0
    with pytest.raises(InputError, match="0..23"):
        modes_mask([27])


def _install(v: Vehicle, base: dict[str, float], figure8: bool, **safety: float) -> OnboardGuard:
    limits = limits_from_profile(v.profile, safety)
    f8 = figure8_for(v.mission, 1.5 * limits.tracking_error_max) if figure8 else None
    guard = OnboardGuard(v.link, v.params, v.cmd)
    guard.install(config_for(limits, v.heartbeat_timeout, base, new_config_id(), figure8=f8))
    v.guard = guard
    return guard


def _connect(sim: SimProcess) -> tuple[Vehicle, dict[str, float]]:
    v = Vehicle.connect(Endpoint("udpout", sim.host, sim.port), PROFILE)
    v.mission = short_mission(v.mission)
    return v, {n: v.params.read(n) for n in v.gain_map.param_names}


@pytest.mark.slow  # default run: the same on ArduCopter SITL: test_sitl_guard_trip
def test_a_box_the_guard_finds_is_the_gains_abort_and_the_trials_go_on(tmp_path):
    with SimProcess("--lockstep", "--vehicle", "copter3d", "--personality", "ardupilot-legacy") as sim:
        v, base = _connect(sim)
        try:
            # The guard's box ends 3 m north; the figure-8 flies 4 m north; the tuner's monitor has the profile's
            # 15 m: only the guard sees the breach.
            guard = _install(v, base, True, x_max_m=3.0)
            v.setup_streams()
            v.ensure_airborne()
            obj = MavlinkObjective(v, base, tmp_path)
            f = obj.fly(v.gain_map.from_params(base), label="box")  # no TrialStopped: the campaign goes on
            message = f.meta["message"]
            assert f.outcome is T.FENCE, (f.outcome, message)
            assert "the onboard guard tripped: box" in message and "north" in message, message
            assert "taken back from the guard's LOITER to GUIDED" in message, message
            record = json.loads((tmp_path / "trial_000.json").read_text())
            assert record["outcome"] == "fence" and record["restored"] is True
            assert guard.trip_code() == 2
            assert v.guided.armed and v.guided.in_mode("guided")
            assert {n: v.params.read(n) for n in base} == pytest.approx(base)
            # the next trial flies in GUIDED as ever: a guard with the profile's box, the figure-8 completes
            guard.remove()
            _install(v, base, True)
            g = obj.fly(v.gain_map.from_params(base), label="next")
            assert g.outcome is T.OK, g.meta["message"]
            print(f"guard trip: {message}")
        finally:
            if v.guard is not None:
                v.guard.remove()
            v.close()


def _hold(seconds: float) -> ManoeuvreSpec:
    return ManoeuvreSpec.from_dict("hold", {"seconds": seconds})


def _guarded_hold(v, base, tmp_path, seconds: float):
    """Install the guard and fly a hold of ``seconds`` with the baseline: (guard, monitor, the flight)."""
    guard = _install(v, base, False)
    v.setup_streams()
    mon = Monitor(limits_from_profile(v.profile), v.stack.modes["guided"], v.stack.mode_name)
    f = fly_manoeuvre(v, _hold(seconds), mon, gains_label="baseline", tlog_path=tmp_path / "hold.tlog",
                      baseline_params=base)
    return guard, mon, f


def test_a_validation_flight_flies_guarded_with_its_hold_mode_declared(tmp_path):
    with SimProcess("--lockstep", "--vehicle", "copter3d", "--personality", "ardupilot-legacy") as sim:
        v, base = _connect(sim)
        try:
            guard, mon, f = _guarded_hold(v, base, tmp_path, 8)
            assert f.outcome is T.OK, f.message
            assert f"KSG: trial armed, modes {int(modes_mask([LOITER]))}" in guard.texts, guard.texts
            assert not any("pilot mode change" in t for t in guard.texts), guard.texts
            assert v.params.read(STATE_PARAM) == 0 and v.params.read(MODES_PARAM) == 0  # ended, GUIDED only again
            # tighter tilt on board than on the ground: steps with stiff gains lean past it, the guard stops them
            guard.remove()
            _install(v, base, False, tilt_max_deg=4.0)
            x0 = v.gain_map.from_params(base)
            x = v.check_trial_gains(x0 * np.where(np.arange(len(x0)) == 0, 1.4, 1.0), x0)
            s = fly_manoeuvre(v, ManoeuvreSpec.from_dict("steps", {}), mon, gains_label="stiff",
                              tlog_path=tmp_path / "steps.tlog", gains=x, baseline_params=base)
            assert s.outcome is T.TILT and s.restored is True, (s.outcome, s.message)
            assert "the onboard guard tripped: tilt" in s.message, s.message
            assert v.guided.armed and v.guided.in_mode("guided")
            print(f"guarded steps: {s.message}")
        finally:
            if v.guard is not None:
                v.guard.remove()
            v.close()


def test_a_pilots_other_mode_during_a_guarded_hold_is_still_a_take_over(tmp_path):
    # the pilot's STABILIZE 12 s (simulated) into the guided stream: during the 30 s hold
    with SimProcess("--lockstep", "--vehicle", "copter3d", "--personality", "ardupilot-legacy",
                    "--set", "SIM_PILOT_MODE=0", "--set", "SIM_FAULT_AFTER=12") as sim:
        v, base = _connect(sim)
        try:
            guard, mon, f = _guarded_hold(v, base, tmp_path, 30)
            hb = v.link.wait_heartbeat(5.0)
            assert f.outcome is T.PILOT and "STABILIZE" in f.message, (f.outcome, f.message)
            assert guard.trip_code() == 4 and "pilot mode change" in f.message, f.message
            assert hb.custom_mode == STABILIZE  # left where the pilot put it
        finally:
            if v.guard is not None:
                v.guard.remove()
            v.close()


@pytest.mark.slow  # a whole campaign with its validation flights (about 30 s)
def test_a_campaigns_validation_flights_fly_guarded(tmp_path):
    import subprocess
    import sys

    from mav_tune_helpers import fresh_read, sim_and_endpoint
    from test_validation_campaign import _profile

    from ksbo_mav.mav.guard_script import GUARD_PARAMS
    from ksbo_mav.mav.tlog import read_tlog

    d = tmp_path / "c"
    with sim_and_endpoint("--vehicle", "copter3d", "--personality", "ardupilot") as (sim, ep):
        r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), "--udp", f"127.0.0.1:{ep.port}",
                            "--profile", str(_profile(tmp_path)), "--budget", "3", "--method", "random", "--prior",
                            "none", "--end", "hold"], capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stderr[-3000:]
        assert fresh_read(sim, list(GUARD_PARAMS), None) == GUARD_PARAMS  # removed with all it added
    assert "validation: the onboard guard watches every flight" in r.stderr
    flights = [json.loads(x) for x in (d / "validation.jsonl").read_text().splitlines() if x.strip()]
    assert flights and all(f["outcome"] == "ok" for f in flights), flights
    armed = {"steps": "KSG: trial armed", "hold": f"KSG: trial armed, modes {1 << LOITER}",
             "auto_mission": f"KSG: trial armed, modes {1 << 3}"}
    for f in flights:
        texts = [str(m.msg.text) for m in read_tlog(f["tlog"]) if m.msg.get_type() == "STATUSTEXT"]
        assert armed[f["manoeuvre"]] in texts, (f["manoeuvre"], [t for t in texts if t.startswith("KSG")])
        assert not any("pilot mode change" in t for t in texts)
