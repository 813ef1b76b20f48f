"""The simulator's battery, low-battery failsafe, RTL and changing conditions: the pure models, and the MAVLink
endpoint in its own process (real UDP on 127.0.0.1, lockstep)."""

from __future__ import annotations

import numpy as np
import pytest

from ksbo_sim.battery import Battery
from ksbo_sim.conditions import Conditions
from ksbo_sim.testing import GUIDED, running_sim

RTL = 6


def test_battery_voltage_falls_with_discharge_and_sags_under_load():
    b = Battery(1000.0, cells=3, hover_current_a=10.0)
    b.step(1.0, armed=True, airborne=True, load=1.0)
    v_full = b.voltage
    assert 12.0 < v_full < 12.6 and b.current_a == pytest.approx(10.0)
    b.step(1.0, armed=True, airborne=True, load=1.5)
    assert b.voltage < v_full  # more current, more sag
    fired = [b.step(1.0, armed=True, airborne=True, load=1.0) for _ in range(400)]
    assert sum(fired) == 1 and b.low  # fired once, latched
    assert b.remaining_pct < 15 and b.consumed_mah > 1000 * 0.85


def test_conditions_drift_step_and_wind():
    c = Conditions(drift=0.1, step_at_s=120.0, step_factor=0.5, wind_mps=1.0, wind_rise_per_min=2.0,
                   turbulence=0.0, seed=1)
    assert c.authority() == 1.0
    for _ in range(60 * 50):
        c.step(0.02, airborne=True)
    assert c.authority() == pytest.approx(0.9) and c.mean_wind() == pytest.approx(3.0)
    for _ in range(61 * 50):
        c.step(0.02, airborne=True)
    assert c.authority() == pytest.approx(0.8 * 0.5, abs=0.01)
    c.step(0.02, airborne=False)  # the clock is flight time: nothing moves on the ground
    assert c.flight_s == pytest.approx(121.0)
    assert c.wind_accel(np.zeros(3))[0] > 0 and Conditions().wind_accel(np.ones(3))[0] == 0.0


def _takeoff(cli) -> None:
    assert cli.command(176, 1, GUIDED) == 0
    assert cli.command(400, 1) == 0
    assert cli.command(22, 0, 0, 0, 0, 0, 0, 1.0) == 0
    assert cli.step(4.0) == 0


@pytest.mark.network
@pytest.mark.timeout(60)
def test_low_battery_failsafe_switches_to_rtl_lands_at_home_and_refuses_to_arm():
    with running_sim("--lockstep", "--battery", "120,3,10") as (sim, cli):
        cli.hello()
        assert cli.step(1.1) == 0  # lockstep: telemetry flows only as time advances
        cli.drain()
        st = cli.last["SYS_STATUS"]
        assert st.voltage_battery > 12000 and st.battery_remaining == 100
        _takeoff(cli)
        cli.setpoint((0.8, 0.0, -1.0), mask=0x0DF8)  # a hover away from home
        assert cli.step(5.0) == 0
        cli.drain()
        st = cli.last["SYS_STATUS"]
        assert st.current_battery > 500 and st.battery_remaining < 100
        bs = cli.last["BATTERY_STATUS"]
        assert bs.current_consumed > 0 and bs.voltages[0] < 4200
        # 120 mAh at 10 A lasts ~43 s: step until the failsafe fires
        for _ in range(12):
            cli.step(5.0)
            cli.drain()
            if any("Battery 1 is low" in t for t in cli.texts):
                break
        assert any("Battery 1 is low" in t for t in cli.texts)
        cli.step(1.0)
        cli.drain()
        hb = cli.last["HEARTBEAT"]
        assert hb.custom_mode == RTL and hb.system_status == 5 and hb.base_mode & 128
        for _ in range(12):  # back home at 1 m/s, then down at 0.5 m/s
            cli.step(2.0)
            cli.drain()
            if not cli.last["HEARTBEAT"].base_mode & 128:
                break
        lpn = cli.last["LOCAL_POSITION_NED"]
        assert not cli.last["HEARTBEAT"].base_mode & 128 and abs(lpn.x) < 0.05 and abs(lpn.z) < 0.05
        assert cli.command(400, 1) != 0  # the pre-arm check refuses the empty pack
        assert any("Battery 1 low" in t for t in cli.texts)


@pytest.mark.network
@pytest.mark.timeout(60)
def test_wind_is_reported_and_pushes_the_vehicle():
    with running_sim("--lockstep", "--wind", "0,0,20,0", "--wind-step", "8:4") as (sim, cli):
        cli.hello()
        _takeoff(cli)
        cli.drain()
        w = cli.last["WIND"]
        assert w.speed == pytest.approx(0.0)
        cli.setpoint((0.0, 0.0, -1.0), mask=0x0DF8)
        assert cli.step(5.0) == 0
        cli.drain()
        w = cli.last["WIND"]
        assert w.speed == pytest.approx(4.0) and w.direction == pytest.approx(180.0)
        lpn = cli.last["LOCAL_POSITION_NED"]
        assert lpn.x > 0.005  # blown north of the hold point (the integrator has not caught up yet)


def test_drag_rises_with_flight_time_and_the_option_parses():
    import argparse

    from ksbo_sim.mavlink.options import add_condition_arguments, condition_objects

    c = Conditions(drag_scale=1.2, drag_rise_per_min=0.5)
    assert c.active and c.drag() == pytest.approx(1.2)
    for _ in range(60 * 50):
        c.step(0.02, airborne=True)
    c.step(0.02, airborne=False)
    assert c.drag() == pytest.approx(1.7)
    p = argparse.ArgumentParser()
    p.add_argument("--seed", type=int, default=None)
    add_condition_arguments(p)
    _, cond = condition_objects(p.parse_args(["--drag", "1,0.03"]))
    assert (cond.drag_scale, cond.drag_rise_per_min) == (1.0, pytest.approx(0.03))
    with pytest.raises(Exception, match="SCALE must be positive"):
        condition_objects(p.parse_args(["--drag", "0"]))
