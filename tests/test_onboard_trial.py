"""The figure-8 flown on board by the onboard guard, on the built-in simulator (its simulated guard flies it as the
Lua does): the protocol (KSG_F8 starts it, KSG_T0 gives its t = 0), a trial that sends no setpoint during the
figure-8 yet scores like a streamed one, a tlog that replays to the same score, and the tuner's own monitor
stopping it. The same on ArduCopter SITL: ``test_sitl_onboard_trial.py``.

The simulator is the JSBSim copter with ArduPilot's (legacy) parameter names, in lockstep, flying a short
figure-8 (8 s period, 2 s lead-in) so that a trial takes seconds; a whole ``tune`` campaign with the defaults
(marked slow) flies every figure-8 on board.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from onboard_helpers import fly_pair_of_trials, guarded_and_airborne, sent_setpoints, short_mission

from ksbo_mav.flightlog.tlogs import read_any_tlog
from ksbo_mav.mav.guard_script import GUARD_PARAMS, config_for, figure8_for, render_script
from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.mission import Mission
from ksbo_mav.mav.monitor import limits_from_profile
from ksbo_mav.mav.objective import MavlinkObjective
from ksbo_mav.mav.onboard_trial import full_t0
from ksbo_mav.mav.outcome import TrialOutcome
from ksbo_mav.mav.tlog import read_tlog
from ksbo_mav.mav.trajectory import trajectory_from_tlog
from ksbo_mav.mav.vehicle import Vehicle
from ksbo_sim.process import SimProcess

PROFILE = "ardupilot-copter"


def test_t0_from_the_guards_modulo_and_a_later_vehicle_time():
    assert full_t0(5000.0, 5000) == 5000
    assert full_t0(5000.0, 65_000) == 5000
    wrapped = (1 << 24) + 300  # the figure-8 started after 4.66 h of vehicle time: KSG_T0 holds 300
    assert full_t0(300.0, wrapped + 40_000) == wrapped
    assert full_t0(float((1 << 24) - 10), (1 << 24) + 20) == (1 << 24) - 10  # started just before the wrap


def test_the_rendered_script_carries_the_missions_figure8():
    f8 = figure8_for(short_mission(Mission.from_profile(_profile())), 7.5)
    assert f8.duration_ms == 16_000 and f8.lead_in == 2.0 and f8.amp_north == 4.0
    text = render_script(config_for(limits_from_profile(_profile()), 3.0, {"PSC_POSXY_P": 1.0}, 7,
                                    figure8=f8)).decode()
    assert "local F8_AMP_N, F8_AMP_E, F8_PERIOD, F8_UP, F8_LEAD = 4.0, 1.0, 8.0, 10.0, 2.0" in text
    assert "local F8_DURATION_MS, F8_TICK_MS, TRACK_MAX = 16000, 10, 7.5" in text
    plain = render_script(config_for(limits_from_profile(_profile()), 3.0, {"PSC_POSXY_P": 1.0}, 7)).decode()
    assert "local F8_DURATION_MS, F8_TICK_MS, TRACK_MAX = 0, 10, 0" in plain  # no figure-8: never starts one


def _profile():
    from ksbo_mav.profiles import load_profile

    return load_profile(PROFILE)


@pytest.fixture(scope="module")
def copter():
    with SimProcess("--lockstep", "--vehicle", "copter3d", "--personality", "ardupilot-legacy") as sim:
        v = Vehicle.connect(Endpoint("udpout", sim.host, sim.port), PROFILE)
        try:
            base, guard = guarded_and_airborne(v)
            yield v, base
            v.guard = None
            guard.remove()
            for name, default in GUARD_PARAMS.items():
                assert v.params.read(name) == default
        finally:
            v.close()


def test_an_onboard_trial_streams_nothing_and_scores_as_a_streamed_one(copter, tmp_path):
    v, base = copter
    board, ground = fly_pair_of_trials(v, base, tmp_path)
    for f in (board, ground):
        assert f.outcome is TrialOutcome.OK, f.meta["message"]
        assert f.score["complete"], f.score
    assert board.meta["trajectory"]["on_board"] and not ground.meta["trajectory"]["on_board"]
    assert sent_setpoints(board.meta["tlog"]) == 0  # the guard set every target of the figure-8
    assert sent_setpoints(ground.meta["tlog"]) >= ground.score["L_expected"]
    assert any("figure-8 started" in t for t in v.guard.texts) and any("figure-8 done" in t for t in v.guard.texts)
    rb, rg = board.score["rms_lap2_m"], ground.score["rms_lap2_m"]
    print(f"lap-2 RMS on board {rb:.4f} m, streamed {rg:.4f} m")
    assert rb < 1.5 * rg and rg < 1.5 * rb  # the same figure-8: a wrong reference on board would be metres off


def test_the_tlog_of_an_onboard_trial_replays_to_the_live_score(copter, tmp_path):
    v, base = copter
    obj = MavlinkObjective(v, base, tmp_path)
    live = obj.fly(v.gain_map.from_params(base), label="replay")
    traj, info, _ = trajectory_from_tlog(read_tlog(live.meta["tlog"]))
    again = v.mission.score(traj, rms_ref=info.get("rms_ref"))
    assert info["on_board"] and again["rms_lap2_m"] == pytest.approx(live.score["rms_lap2_m"], rel=1e-9)
    assert math.isfinite(again["rms_lap2_m"])
    # `ksbo-mav score`'s flight analysis compares with the figure-8 the guard flew, which the tuner never sent
    log = read_any_tlog(Path(live.meta["tlog"]))
    t0 = info["t0_ms"] / 1000.0
    inside = (log.commanded.t >= t0) & (log.commanded.t <= t0 + v.mission.steps * v.mission.dt)
    assert inside.sum() >= v.mission.steps and any("onboard guard flew" in w for w in log.warnings)


def test_the_tuners_monitor_stops_the_figure8_on_board(copter, tmp_path):
    v, base = copter
    # A tracking limit the figure-8's lead-in already breaks: the ground monitor aborts the trial mid figure-8.
    obj = MavlinkObjective(v, base, tmp_path, safety={"tracking_error_max_m": 0.02})
    f = obj.fly(v.gain_map.from_params({**base, "PSC_POSXY_P": 0.5}), label="abort")
    assert f.outcome is TrialOutcome.TRACK, (f.outcome, f.meta["message"])
    assert f.meta["restored"] and 0 < f.meta["trajectory"]["L"] < v.mission.steps
    assert v.params.read("KSG_F8") == 0 and v.params.read("KSG_T0") == -1  # the guard ended the figure-8
    pos = v.guided.position()
    v.guided.wait(2.0)
    assert np.linalg.norm(v.guided.position() - pos) < 1.0  # held where it was stopped, not flying on
    assert v.params.read("PSC_POSXY_P") == pytest.approx(base["PSC_POSXY_P"])


def test_a_ground_trial_on_a_guard_with_a_figure8_streams_as_before(copter, tmp_path):
    v, base = copter
    obj = MavlinkObjective(v, base, tmp_path)
    obj.trial_flight.on_board = False
    f = obj.fly(v.gain_map.from_params(base), label="ground")
    assert f.outcome is TrialOutcome.OK and sent_setpoints(f.meta["tlog"]) >= v.mission.steps
    assert not f.meta["trajectory"]["on_board"]


@pytest.mark.slow  # a whole campaign (about 2 minutes)
@pytest.mark.timeout(300)
def test_a_campaign_on_arducopter_flies_its_figure8s_on_board_by_default(tmp_path, capsys):
    from mav_tune_helpers import fresh_read, sim_and_endpoint

    from ksbo_mav.cli import main

    d = tmp_path / "c"
    with sim_and_endpoint("--vehicle", "copter3d", "--personality", "ardupilot-legacy") as (sim, ep):
        rc = main(["tune", str(d), "--udp", f"127.0.0.1:{ep.port}", "--budget", "2", "--prior", "none",
                   "--confirm", "1", "--validation", "off", "--end", "hold", "--json"])
        out = capsys.readouterr()
        assert rc == 0, out.err
        assert "trials: the figure-8 flown on board by the onboard guard" in out.err
        records = [json.loads(p.read_text()) for p in sorted((d / "trials").glob("trial_*.json"))]
        assert len(records) >= 3 and all(r["trajectory"]["on_board"] for r in records), \
            [(r["label"], r["trajectory"].get("on_board")) for r in records]
        assert all(r["score"]["complete"] for r in records)
        assert all(sent_setpoints(r["tlog"]) == 0 for r in records)
        left = fresh_read(sim, list(GUARD_PARAMS), "ardupilot-copter")
        assert left == GUARD_PARAMS  # the guard removed with everything it added
