"""Guided flight through the MAVLink simulator (own process, real UDP on 127.0.0.1, lockstep)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ksbo_sim.testing import (CMD_SIM_RESET, CMD_SIM_SET_STATE, GUIDED, LAND, LOITER, MASK_POS, fly_figure8,
                              running_sim)

from ksbo_mav.profiles import load_profile
from ksbo_mav.scoring import score, score_rollout
from ksbo_sim import EpisodeConfig, simulate
from ksbo_task.figure8 import Figure8

pytestmark = [pytest.mark.network, pytest.mark.timeout(60)]


def f32(a) -> np.ndarray:
    """What survives a trip through a MAVLink float field."""
    return np.asarray(a, dtype=float).astype(np.float32).astype(float)


class WireFigure8(Figure8):
    """The figure-8 as the vehicle receives it: every setpoint field rounded to float32 by the wire format."""

    def state(self, t):
        return f32(super().state(t))


def _airborne(cli, alt: float = 1.0) -> None:
    assert cli.command(176, 1, GUIDED) == 0
    assert cli.command(400, 1) == 0
    assert cli.command(22, 0, 0, 0, 0, 0, 0, alt) == 0
    for msg_id in (30, 32, 375):  # ATTITUDE, LOCAL_POSITION_NED, ACTUATOR_OUTPUT_STATUS at 50 Hz sim time
        assert cli.interval(msg_id, 50) == 0
    assert cli.step(4.0) == 0
    assert "Takeoff complete" in cli.texts


def test_figure8_over_mavlink_scores_like_in_process_simulator():
    """Arm, take off, fly the lap-2-scored figure-8 by streaming pos+vel+acc setpoints, land.

    The P(a) of the telemetry equals the in-process P(a) for the same gains and initial state. The closed loop
    is chaotic (a 1e-12 m change of the initial x moves P by ~1e-6, 1e-7 m by ~1e-3), so "the same" has two
    levels: bit-level against `simulate` fed what the wire carries (float32 setpoints, gains, initial
    velocity), and within that sensitivity against `simulate` with exact float64 inputs.
    """
    cfg = EpisodeConfig()
    refs = cfg.reference()
    gains = load_profile("sim-planar").default
    v0 = np.array([0.3, -0.2])  # initial planar (vx, vz) at the figure-8 origin
    with running_sim("--lockstep") as (sim, cli):
        cli.hello()
        _airborne(cli)
        # Start the episode as simulate() does: at the origin (x 0, z 1) with v0, controller state zeroed.
        assert cli.command(CMD_SIM_SET_STATE, 0.0, 0.0, -1.0, v0[0], 0.0, -v0[1]) == 0
        cli.drain()
        out = fly_figure8(cli, refs, cfg.steps)
        # End on a position-only target, then land (the flight-stack flow); the vehicle disarms on the ground.
        cli.setpoint((0.0, 0.0, -1.0), mask=MASK_POS)
        assert cli.command(176, 1, LAND) == 0
        assert cli.step(5.0) == 0
        hb = cli.last["HEARTBEAT"]
        assert not hb.base_mode & 128 and hb.system_status == 3
        assert "Landed, disarming" in cli.texts
        assert not any(t.startswith("Crash") for t in cli.texts)

    mav = score(out["states"], refs[1:], np.arange(cfg.steps), cfg.steps, out["thrust"])
    init = np.array([0.0, v0[0], 1.0, v0[1], 0.0, 0.0])
    wire = simulate(f32(gains), f32(init), replace(cfg, figure8=WireFigure8()))
    wire_score = score(wire.states[:, 1:], refs[1:], np.arange(cfg.steps), wire.L, wire.inputs)
    exact = score_rollout(simulate(gains, init))
    assert mav.complete[0] and mav.P[0] > 0.1
    assert mav.P[0] == pytest.approx(wire_score.P[0], abs=1e-6)
    np.testing.assert_allclose(out["states"], wire.states[0, 1:], atol=1e-5)
    assert mav.P[0] == pytest.approx(exact.P[0], abs=5e-3)


def test_geofence_crash_is_reported_and_recoverable():
    with running_sim("--lockstep") as (sim, cli):
        cli.hello()
        _airborne(cli)
        cli.setpoint((3.0, 0.0, -1.0), mask=MASK_POS)  # 3 m north: outside FENCE_X_MAX = 2 m
        assert cli.step(10.0) == 0
        assert any(t.startswith("Crash: |x| > x limit") for t in cli.texts)
        hb = cli.last["HEARTBEAT"]
        assert hb.system_status == 5 and not hb.base_mode & 128  # CRITICAL, disarmed
        assert cli.command(22, 0, 0, 0, 0, 0, 0, 1.0) == 2  # takeoff refused: not armed
        assert cli.command(400, 1) == 0  # re-arm puts the vehicle back on the ground at home
        assert "Vehicle reset to home after crash" in cli.texts
        cli.drain()
        assert cli.command(22, 0, 0, 0, 0, 0, 0, 1.0) == 0
        assert cli.step(4.0) == 0
        lp, hb = cli.last["LOCAL_POSITION_NED"], cli.last["HEARTBEAT"]
        assert hb.system_status == 4 and hb.base_mode & 128  # ACTIVE, armed
        assert abs(lp.x) < 0.05 and abs(lp.z + 1.0) < 0.1
        # Into the ground: EMERGENCY; the documented reset command (MAV_CMD_USER_3) clears it without arming.
        cli.setpoint((0.0, 0.0, 0.5), mask=MASK_POS)
        assert cli.step(10.0) == 0
        assert any(t.startswith("Crash: hit the ground") for t in cli.texts)
        assert cli.last["HEARTBEAT"].system_status == 6
        assert cli.command(CMD_SIM_RESET) == 0
        assert cli.step(1.0) == 0
        hb, lp = cli.last["HEARTBEAT"], cli.last["LOCAL_POSITION_NED"]
        assert hb.system_status == 3 and not hb.base_mode & 128 and (lp.x, lp.z) == (0.0, 0.0)


def test_velocity_setpoint_times_out_to_hold():
    with running_sim("--lockstep", "--set", "SIM_SP_TIMEOUT=1") as (sim, cli):
        cli.hello()
        _airborne(cli)
        assert cli.command(400, 0) == 2  # no disarm in flight without the force flag
        assert "Disarm: vehicle is flying (use force)" in cli.texts
        cli.setpoint((float("nan"),) * 3, (0.2, 0.0, 0.0), mask=0x0DC7)  # velocity only, 0.2 m/s north
        assert cli.step(4.0) == 0
        assert "Guided setpoint timeout: holding position" in cli.texts
        a = cli.last["LOCAL_POSITION_NED"]
        assert cli.step(2.0) == 0
        b = cli.last["LOCAL_POSITION_NED"]
        assert 0.1 < a.x < 0.4  # moved ~0.2 m during the 1 s the setpoint lived
        assert abs(b.x - a.x) < 0.05 and abs(b.vx) < 0.05


def test_pilot_mode_switch_mid_stream():
    """SIM_PILOT_MODE + SIM_FAULT_AFTER: 1 s into the setpoint stream a 'pilot' selects LOITER."""
    with running_sim("--lockstep", "--set", "SIM_FAULT_AFTER=1") as (sim, cli):
        cli.hello()
        _airborne(cli)
        echo = cli.param_set("SIM_PILOT_MODE", LOITER, ptype=6)
        assert echo.param_value == LOITER and echo.param_type == 6
        modes = []
        for _ in range(100):  # 2 s of hover setpoints
            cli.setpoint((0.0, 0.0, -1.0))
            hb = cli.conn.recv_match(type="HEARTBEAT", blocking=False)
            if hb:
                modes.append(hb.custom_mode)
        assert cli.step(1.0) == 0
        hb = cli.last["HEARTBEAT"]
        assert hb.custom_mode == LOITER and hb.base_mode & 128
        assert "Pilot switched mode to LOITER" in cli.texts
        assert cli.param_read("SIM_PILOT_MODE").param_value == -1  # one-shot
