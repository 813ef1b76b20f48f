"""The figure-8 flown on board by the onboard guard's Lua script on a real ArduCopter SITL: one short figure-8
(16 s) on board, then the same streamed from the ground, through the tuner's own objective. On board, no setpoint
goes over the link during the figure-8, the guard reports its start and end, the lap scores complete and like the
streamed one, and the tlog replays to the live score."""

from __future__ import annotations

import pytest
from conftest import sitl_or_skip
from onboard_helpers import fly_pair_of_trials, guarded_and_airborne, sent_setpoints
from ksbo_sim.sitl_instances import release_stopped

from ksbo_mav.mav.guard_script import GUARD_PARAMS
from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.outcome import TrialOutcome
from ksbo_mav.mav.tlog import read_tlog
from ksbo_mav.mav.trajectory import trajectory_from_tlog
from ksbo_mav.mav.vehicle import Vehicle

pytestmark = [pytest.mark.sitl, pytest.mark.network, pytest.mark.timeout(600)]


@pytest.mark.slow  # default run: the ArduPilot SITL campaign of test_sitl_ardupilot flies its trials on board
def test_onboard_figure8_on_arducopter_sitl(tmp_path):
    sitl = sitl_or_skip("ardupilot", 5)  # booted with SCR_ENABLE 1
    try:
        v = Vehicle.connect(Endpoint("tcp", "127.0.0.1", sitl.tcp_port), "ardupilot-copter")
        try:
            base, guard = guarded_and_airborne(v)
            board, ground = fly_pair_of_trials(v, base, tmp_path)
            for f in (board, ground):
                assert f.outcome is TrialOutcome.OK, f.meta["message"]
                assert f.score["complete"], f.score
            assert board.meta["trajectory"]["on_board"]
            assert sent_setpoints(board.meta["tlog"]) == 0
            assert sent_setpoints(ground.meta["tlog"]) >= ground.score["L_expected"]
            assert any("figure-8 started" in t for t in guard.texts), guard.texts
            assert any("figure-8 done" in t for t in guard.texts), guard.texts
            rb, rg = board.score["rms_lap2_m"], ground.score["rms_lap2_m"]
            print(f"lap-2 RMS on board {rb:.4f} m, streamed {rg:.4f} m; guard said {guard.texts}")
            assert rb < 1.5 * rg and rg < 1.5 * rb
            traj, info, _ = trajectory_from_tlog(read_tlog(board.meta["tlog"]))
            again = v.mission.score(traj, rms_ref=info.get("rms_ref"))
            assert again["rms_lap2_m"] == pytest.approx(rb, rel=1e-9)
            v.guard = None
            guard.remove()
            for name, default in GUARD_PARAMS.items():
                assert v.params.read(name) == default
            v.land()
        finally:
            v.close()
    finally:
        sitl.stop()
        release_stopped()
