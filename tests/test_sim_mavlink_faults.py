"""Fault injection (packet loss, silence, delay), estimator noise and the real-time clock of the
MAVLink simulator (own process, real UDP on 127.0.0.1)."""

from __future__ import annotations

import time

import numpy as np
import pytest

from ksbo_sim.testing import CMD_SIM_SET_STATE, GUIDED, fly_figure8, running_sim

from ksbo_mav.profiles import load_profile
from ksbo_mav.scoring import score, score_rollout
from ksbo_sim import EpisodeConfig, simulate

pytestmark = [pytest.mark.network, pytest.mark.timeout(60)]


def _reads_answered(cli, n: int) -> int:
    """Send n PARAM_REQUEST_READs, count the answers."""
    for i in range(n):
        cli.mav.param_request_read_send(1, 1, b"", i % 9)
    answered = 0
    while cli.recv("PARAM_VALUE", 1.0) is not None:
        answered += 1
    return answered


def test_incoming_and_outgoing_loss():
    with running_sim("--lockstep", "--seed", "3") as (sim, cli):
        cli.hello()
        assert _reads_answered(cli, 40) == 40
        assert cli.param_set("SIM_PKT_LOSS_IN", 0.5).param_value == 0.5
        half = _reads_answered(cli, 200)
        assert 50 < half < 150  # binomial(200, 0.5): outside this range with probability < 1e-12
        # Switch it off again (retrying: the switch itself is subject to the loss), then drop everything sent.
        for _ in range(20):
            if cli.param_set("SIM_PKT_LOSS_IN", 0.0, timeout=0.5) is not None:
                break
        assert _reads_answered(cli, 20) == 20
        assert cli.param_set("SIM_PKT_LOSS_OUT", 1.0).param_value == 1.0  # echoed before the switch acts
        assert _reads_answered(cli, 20) == 0
        assert cli.recv("HEARTBEAT", 2.5) is None  # even the idle heartbeats are lost


def test_mute_then_recover_and_delay():
    with running_sim("--lockstep") as (sim, cli):
        cli.hello()
        echo = cli.param_set("SIM_MUTE_S", 3.0)
        assert echo is not None and echo.param_value == 3.0  # the echo leaves before the silence starts
        assert _reads_answered(cli, 5) == 0
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and cli.param_read("POS_X_P", timeout=0.5) is None:
            pass
        assert cli.param_read("SIM_MUTE_S").param_value == 0.0  # one-shot: talking again
        assert cli.param_set("SIM_DELAY_MS", 300.0).param_value == 300.0
        sent = time.monotonic()
        m = cli.param_read("POS_X_P", timeout=5.0)
        assert m is not None and time.monotonic() - sent >= 0.3  # a lower bound only: delay was added


def test_noisy_estimator_flies_the_figure8_within_noise():
    cfg = EpisodeConfig()
    refs = cfg.reference()
    with running_sim("--lockstep", "--noise", "0.003,0.01,0.05", "--seed", "1") as (sim, cli):
        cli.hello()
        assert cli.command(176, 1, GUIDED) == 0 and cli.command(400, 1) == 0
        assert cli.command(22, 0, 0, 0, 0, 0, 0, 1.0) == 0
        for msg_id in (30, 32, 375):
            assert cli.interval(msg_id, 50) == 0
        assert cli.step(4.0) == 0
        assert cli.command(CMD_SIM_SET_STATE, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0) == 0
        cli.drain()
        out = fly_figure8(cli, refs, cfg.steps)
        east = cli.last["LOCAL_POSITION_NED"].y
    noisy = score(out["states"], refs[1:], np.arange(cfg.steps), cfg.steps, out["thrust"])
    exact = score_rollout(simulate(load_profile("sim-planar").default, np.array([0.0, 0.0, 1.0, 0.0, 0.0, 0.0])))
    # The controller flies the truth; only the reported (estimated) states carry the noise, so P stays close.
    print("P noisy", noisy.P[0], "exact", exact.P[0])
    assert noisy.complete[0] and abs(noisy.P[0] - exact.P[0]) < 0.05
    # The estimate is not the truth: the planar vehicle's true east position is exactly 0.
    assert east != 0.0 and abs(east) < 0.05


def test_real_time_clock_with_speedup():
    with running_sim("--speedup", "20") as (sim, cli):
        cli.hello()
        assert cli.command(176, 1, GUIDED) == 0 and cli.command(400, 1) == 0
        assert cli.command(22, 0, 0, 0, 0, 0, 0, 1.0) == 0
        assert cli.interval(32, 10) == 0
        lp = cli.recv("LOCAL_POSITION_NED", 30.0, lambda m: m.z < -0.95)
        assert lp is not None and lp.time_boot_ms >= 1900  # >= 1.9 s of simulated climb at 0.5 m/s
        assert cli.command(31011, 1.0) == 2  # lockstep stepping is refused in real time


def test_param_write_failure_injection():
    """SIM_PSET_FAIL = 1: every write of a vehicle parameter is refused and echoed with the old value (what a
    client's set-and-verify must catch); SIM_* switches stay writable so the fault can be turned off."""
    with running_sim("--lockstep") as (sim, cli):
        cli.hello()
        assert cli.param_set("SIM_PSET_FAIL", 1.0).param_value == 1.0
        assert cli.param_set("POS_X_P", 0.3).param_value == pytest.approx(0.15, rel=1e-7)
        assert "Param write failed: POS_X_P (SIM_PSET_FAIL)" in cli.texts
        assert cli.param_set("SIM_PSET_FAIL", 0.0).param_value == 0.0
        assert cli.param_set("POS_X_P", 0.3).param_value == pytest.approx(0.3, rel=1e-7)
