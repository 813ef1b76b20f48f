"""Moving starts of planar MAVLink trials (ksbo_mav.mav.approach): the vehicle passes the figure-8 start at the
task's random initial velocity, so a MAVLink trial flies the in-process episode from the same start, and gains
that fail only once the vehicle moves fail on the vehicle too."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from mav_tune_helpers import sim_and_endpoint

from ksbo_mav.errors import InputError
from ksbo_mav.mav.approach import ACCEL, CRUISE_S, Approach, approach_outside, start_velocity, stress_velocity
from ksbo_mav.mav.mission import Mission
from ksbo_mav.mav.objective import MavlinkObjective
from ksbo_mav.mav.vehicle import Vehicle
from ksbo_mav.profile_sections import MissionSpec
from ksbo_mav.profiles import load_profile
from ksbo_mav.simulated.planar_objective import SimObjective
from ksbo_task.limit_checks import planar_monitor_limits
from ksbo_task.starts import random_initial_states

#: A recommendation of a MAVLink campaign (method ksbo, test seed 1): 0.79 from a settled hover, but
#: its pitch loop diverges from some of the task's moving starts (E[P] 0.34 over the 8 fixed starts).
BISTABLE = np.array([0.23723692712545302, 0.03178322529108468, 0.10997401710788994, 0.4160030885005886,
                     0.046562993149018635, 0.4693669934198613, 37808.323008558866, 244.43470109568074,
                     4021.0898504699594])


def test_start_velocity_is_the_tasks_random_start_seeded_by_campaign_and_trial() -> None:
    u = start_velocity("figure8-xz", 1.0, 7, 3)
    s = random_initial_states(1, np.random.default_rng([7, 3]), v_max=1.0)[0]
    np.testing.assert_allclose(u, [s[1], 0.0, -s[3]])  # planar (vx, vz up) -> NED
    assert np.array_equal(u, start_velocity("figure8-xz", 1.0, 7, 3))  # a resume flies the same start
    assert not np.array_equal(u, start_velocity("figure8-xz", 1.0, 7, 4))
    speeds = [np.linalg.norm(start_velocity("figure8-xz", 1.0, 0, i)) for i in range(200)]
    assert 0.0 <= min(speeds) < 0.1 and 0.9 < max(speeds) <= 1.0
    assert not start_velocity("figure8-xz", 0.0, 0, 1).any() and not start_velocity("figure8-ne", 1.0, 0, 1).any()


def test_approach_goes_from_rest_to_the_start_at_the_start_velocity() -> None:
    start, u, dt = np.array([0.0, 0.0, -1.0]), np.array([0.6, 0.0, 0.8]), 0.02
    a = Approach(start, u, dt)
    assert a.speed == pytest.approx(1.0) and a.steps == round((1.0 / ACCEL + CRUISE_S) / dt)
    p0, v0, _ = a.setpoint(0)
    np.testing.assert_allclose(p0, a.begin)
    np.testing.assert_allclose(v0, 0.0)
    p, v, acc = a.setpoint(a.steps)
    np.testing.assert_allclose(p, start, atol=1e-12)
    np.testing.assert_allclose(v, u)
    np.testing.assert_allclose(acc, 0.0)
    # consistent: the position advances by the mean of consecutive velocities, along u only
    P = np.array([a.setpoint(j)[0] for j in range(a.steps + 1)])
    V = np.array([a.setpoint(j)[1] for j in range(a.steps + 1)])
    np.testing.assert_allclose(np.diff(P, axis=0), 0.5 * (V[1:] + V[:-1]) * dt, atol=1e-12)
    assert np.linalg.norm(a.begin - start) == pytest.approx(a.distance) and a.distance < 0.6
    still = Approach(start, np.zeros(3), dt)
    assert still.steps == 0 and np.array_equal(still.begin, start)


@pytest.mark.parametrize("kw, msg", [
    ({"start_speed_mps": -0.5}, "start_speed_mps must be in"),
    ({"start_speed_mps": 5.0}, "start_speed_mps must be in"),
    ({"start_speed_mps": float("nan")}, "start_speed_mps must be in"),
    ({"type": "figure8-ne", "start_speed_mps": 1.0}, "figure8-xz missions only"),
])
def test_bad_start_speed_is_a_clear_error(kw, msg) -> None:
    with pytest.raises(InputError, match=msg):
        MissionSpec(**kw)


def test_planar_profile_starts_like_the_task_and_copters_from_rest() -> None:
    assert Mission.from_profile(load_profile("sim-planar")).start_speed == 1.0
    assert Mission.from_profile(load_profile("px4-copter")).start_speed == 0.0


@pytest.mark.network
@pytest.mark.timeout(180)
def test_moving_start_trial_flies_the_in_process_episode_and_shows_bistable_gains(tmp_path) -> None:
    """Trial 1 of seed 0 passes the start at (-0.83, up 0.31) m/s. From there the bistable gains trip the tilt
    limit - on the vehicle and in process - while from a settled hover they fly the figure-8 at P 0.79."""
    with sim_and_endpoint() as (sim, ep):
        v = Vehicle.connect(ep)
        try:
            v.setup_streams()
            base = {n: v.params.table[n].value for n in v.gain_map.param_names}
            inproc = SimObjective("sim-planar", monitor=True)
            obj = MavlinkObjective(v, base, tmp_path / "moving", start_seed=0)
            for trial, gains in ((0, v.profile.default), (1, BISTABLE)):
                f = obj.fly(gains)
                u = np.array(f.meta["start_velocity_ned"])
                np.testing.assert_allclose(u, start_velocity("figure8-xz", 1.0, 0, trial))
                assert np.linalg.norm(u) > 0.5
                # the vehicle passed the start at about u (the trial's gains track the approach with some lag)
                first = f.trajectory.states[0]
                assert abs(first[0]) < 0.15 and abs(first[2] - 1.0) < 0.15
                assert abs(first[1] - u[0]) < 0.3 and abs(first[3] + u[2]) < 0.3
                sc, outs = inproc.scores(np.atleast_2d(gains), np.array([[0.0, u[0], 1.0, -u[2], 0.0, 0.0]]),
                                         with_outcomes=True)
                assert f.P == pytest.approx(float(sc.P[0]), abs=0.01)
                assert (f.outcome == "ok") == (outs[0].name == "COMPLETE")
            assert f.outcome == "tilt" and f.meta["restored"]
            obj.mission = dataclasses.replace(obj.mission, start_speed=0.0)  # the same gains from hover
            g = obj.fly(BISTABLE)
            assert g.outcome == "ok" and g.P > 0.75 and g.meta["start_velocity_ned"] == [0.0, 0.0, 0.0]
        finally:
            v.close()


def test_moving_start_that_could_leave_the_abort_box_is_refused() -> None:
    start = Mission.from_profile(load_profile("sim-planar")).start_ned()
    assert approach_outside(start, 1.0, 0.02, planar_monitor_limits()) is None  # the profile's own box fits
    tight = dataclasses.replace(planar_monitor_limits(), z_min=0.6)
    why = approach_outside(start, 1.0, 0.02, tight)
    assert why is not None and "0.55 m from the figure-8 start" in why and "start_speed_mps" in why
    assert approach_outside(start, 0.0, 0.02, tight) is None  # from hover: nothing to reach


@pytest.mark.network
@pytest.mark.timeout(60)
def test_campaign_refuses_a_box_its_moving_starts_leave_before_writing_anything(tmp_path) -> None:
    from ksbo_mav.campaign import Campaign, CampaignConfig

    d = tmp_path / "camp"
    with sim_and_endpoint() as (sim, ep):
        cfg = CampaignConfig(dir=str(d), budget=2, seed=0, prior="none", confirm=0, end="hold",
                             safety={"z_min_m": 0.6})
        with pytest.raises(InputError, match="outside the abort box"):
            Campaign(cfg, ep, log=lambda s: None).run()
    assert not d.exists()


def test_stress_velocity_is_against_the_path_at_nine_tenths_of_the_start_speed_and_zero_without_moving_starts() -> None:
    np.testing.assert_allclose(stress_velocity("figure8-xz", 1.0), [-0.9, 0.0, 0.0])
    np.testing.assert_allclose(stress_velocity("figure8-xz", 0.5), [-0.45, 0.0, 0.0])
    assert not stress_velocity("figure8-xz", 0.0).any() and not stress_velocity("figure8-ne", 1.0).any()


@pytest.mark.slow
@pytest.mark.network
@pytest.mark.timeout(240)
def test_campaign_reflies_from_the_hardest_start_under_refly_stress(tmp_path) -> None:
    """The re-fly phase of a campaign with refly_stress flies its re-flights from the stress start (journalled and
    recorded as such); every other trial draws its random start."""
    import json

    from ksbo_mav.campaign import Campaign, CampaignConfig

    d = tmp_path / "camp"
    with sim_and_endpoint() as (sim, ep):
        cfg = CampaignConfig(dir=str(d), budget=10, seed=0, prior="sim", confirm=0, end="hold",
                             options={"refly_stress": True})
        summary = Campaign(cfg, ep, log=lambda s: None).run()
    journal = [json.loads(line) for line in (d / "journal.jsonl").read_text().splitlines()]
    opt = [e for e in journal if e["kind"] == "opt"]
    assert len(opt) == 10  # the baseline is one of the budget's 10
    assert summary["n_trials"] == len(journal)  # every flight, the baseline re-flights among them
    assert [e["stress"] for e in opt] == [False] * 9 + [True]  # one re-flight (a tenth of the budget)
    recs = [json.loads(Path(e["record"]).read_text()) for e in opt]
    assert recs[-1]["stress_start"] and recs[-1]["start_velocity_ned"] == pytest.approx([-0.9, 0.0, 0.0])
    assert not any(r["stress_start"] for r in recs[:-1])
    assert all(np.linalg.norm(r["start_velocity_ned"]) <= 1.0 for r in recs)
