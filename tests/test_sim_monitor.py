"""The in-process monitor and backup (issue 13): aborted vs crashed flights, plant variants, one limit check."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from ksbo_mav.objective import SimObjective
from ksbo_mav.opt.outcome import Evaluation
from ksbo_sim.episode import BACKUP_GAINS, EpisodeConfig, MonitorConfig, fixed_initial_states, simulate
from ksbo_sim.monitor import FENCE, TILT, TRACK, MonitorLimits, Outcome, check_state, trip_codes
from ksbo_sim.plants import PLANTS

A0 = np.array(BACKUP_GAINS)
SLOW = np.array([0.15, 0.5, 0.1, 0.5, 0.0, 0.2, 3e4, 0.0, 1e4])  # Ix 0.5: the x loop winds up over seconds
FAST = np.array([0.15, 0.0, 0.1, 0.5, 0.0, 0.2, 3e4, 0.0, 0.0])  # Dθ 0: pitch diverges within a second
INIT = fixed_initial_states()


def test_slow_divergence_is_aborted_and_recovered() -> None:
    strict = simulate(SLOW, INIT[1])
    assert strict.reason[0] != 0 and strict.trip is None  # the paper's mode: a crash
    r = simulate(SLOW, INIT[1], EpisodeConfig(monitor=MonitorConfig()))
    assert r.outcomes == [Outcome.ABORTED]
    k = int(r.L[0])
    assert k < strict.L[0] and r.trip[0] != 0
    # After the trip the backup (a0 holding (0, 1)) flew recover_steps inside the environment bounds.
    after = r.states[0, k : k + MonitorConfig().recover_steps + 1]
    assert np.all(np.isfinite(after)) and np.all(np.abs(after[:, 0]) <= 2.0) and np.all(after[:, 2] >= -0.05)
    assert np.hypot(after[-1, 0], after[-1, 2] - 1.0) < np.hypot(after[0, 0], after[0, 2] - 1.0)


def test_fast_divergence_is_a_crash_even_with_the_backup() -> None:
    r = simulate(FAST, INIT[0], EpisodeConfig(monitor=MonitorConfig()))
    assert r.trip[0] == TILT  # the monitor tripped first ...
    assert r.reason[0] != 0 and r.outcomes == [Outcome.CRASHED]  # ... but the backup could not recover


def test_baseline_completes_on_every_plant_with_monitor_and_is_safe() -> None:
    for name in PLANTS:
        obj = SimObjective(seed=0, plant=name, monitor=True)
        P, counts = obj.expected_outcomes(A0)
        assert counts.tolist() == [[8, 0, 0]], name
        assert P[0] > 0.0, name


def test_plants_change_the_flight_and_rows_do_not_depend_on_the_batch() -> None:
    nominal = SimObjective(seed=0).expected(A0)[0]
    for name in ("mass+30", "iyy x0.5", "delay 40ms", "gusts"):
        cfg = EpisodeConfig(plant=PLANTS[name])
        r = simulate(A0, INIT, cfg)
        r_one = simulate(A0, INIT[3], cfg)
        np.testing.assert_allclose(r.states[3], r_one.states[0], rtol=0, atol=1e-12)
        assert not np.allclose(r.states, simulate(A0, INIT).states, equal_nan=True), name
    assert SimObjective(seed=0, plant="nominal").expected(A0)[0] == pytest.approx(nominal, abs=1e-12)


def test_sim_objective_reports_outcomes() -> None:
    obj = SimObjective(seed=3, monitor=True)
    ev = obj(SLOW)
    assert isinstance(ev, Evaluation) and ev.outcome is Outcome.ABORTED and ev.value < 0
    assert isinstance(SimObjective(seed=3)(A0), float)  # strict mode stays a plain float


def test_one_limit_check_for_batch_sample_and_mavlink() -> None:
    from ksbo_mav.mav.monitor import Limits, Monitor

    lim = MonitorLimits(x_max=1.5, z_min=0.2, z_max=1.8, tilt_max_deg=60, tracking_error_max=0.8)
    states = np.array([[0, 0, 1, 0, 0, 0], [1.6, 0, 1, 0, 0, 0], [0, 0, 1, 0, 1.2, 0], [0.5, 0, 1.7, 0, 0, 0]])
    ref = np.array([0.0, 1.0])
    assert trip_codes(lim, states, ref).tolist() == [0, FENCE, TILT, TRACK]
    names = [None, "fence", "tilt", "track"]
    for s, want in zip(states, names):
        got = check_state(lim, s[0], 0.0, s[2], s[4], (0.0, 0.0, 1.0))
        assert (got and got[0]) == want
    mon = Monitor(Limits(x_max=1.5, z_min=0.2, z_max=1.8, tilt_max_deg=60, tracking_error_max=0.8), guided_mode=4)
    for s, want in zip(states, names):
        lpn = SimpleNamespace(x=s[0], y=0.0, z=-s[2])
        att = SimpleNamespace(pitch=s[4], roll=0.0)
        got = mon.check_sample(lpn, att, np.array([0.0, 0.0, -1.0]))
        assert (got and got[0]) == want
    assert mon.check_sample(SimpleNamespace(x=math.nan, y=0.0, z=-1.0), None, None)[0] == "fence"
