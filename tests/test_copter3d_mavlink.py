"""The JSBSim copter through the MAVLink simulator endpoint:
`python -m ksbo_sim.mavlink --vehicle copter3d --personality ...`.

Own process, real UDP on 127.0.0.1, lockstep. Checks the identity and parameter encoding of each personality,
and flies the horizontal figure-8 over MAVLink against the in-process lap-2 error.
"""

from __future__ import annotations

import struct
import time

import numpy as np
import pytest

from ksbo_sim.testing import GUIDED, MASK_POS, running_sim

from ksbo_sim.copter3d import Copter3D, fly
from ksbo_sim.copter3d.mission import tracking_rms
from ksbo_task.figure8_ne import Figure8H

pytestmark = [pytest.mark.network, pytest.mark.timeout(120)]


def _bytewise(value: float) -> int:
    return struct.unpack("<i", struct.pack("<f", value))[0]


@pytest.mark.parametrize(("personality", "autopilot", "gain", "int_name", "int_value", "encoding"), [
    ("ardupilot", 3, "PSC_NE_POS_P", "ANGLE_MAX", 3000, "c_cast"),
    ("ardupilot-legacy", 3, "PSC_POSXY_P", "ANGLE_MAX", 3000, "c_cast"),
    ("px4", 12, "MPC_XY_P", "SYS_AUTOSTART", 4001, "bytewise"),
])
def test_identity_and_parameters_per_personality(personality, autopilot, gain, int_name, int_value, encoding):
    with running_sim("--lockstep", "--vehicle", "copter3d", "--personality", personality) as (sim, cli):
        hb = cli.hello()
        assert hb.autopilot == autopilot and hb.type == 2
        pv = cli.param_read(int_name)
        assert pv is not None and pv.param_type == 6  # MAV_PARAM_TYPE_INT32
        got = _bytewise(pv.param_value) if encoding == "bytewise" else pv.param_value
        assert got == int_value
        echo = cli.param_set(gain, 1.25)
        assert echo is not None and echo.param_value == pytest.approx(1.25)
        assert echo.param_index == (65535 if personality.startswith("ardupilot") else 0)  # fact sheet 2
        assert cli.param_read(gain).param_value == pytest.approx(1.25)
        other = "PSC_POSXY_P" if personality == "ardupilot" else "PSC_NE_POS_P"
        assert cli.param_read(other, timeout=1.0) is None  # the other generation does not exist


def test_figure8_over_mavlink_matches_in_process():
    fig = Figure8H()
    with running_sim("--lockstep", "--vehicle", "copter3d", "--personality", "ardupilot-legacy") as (sim, cli):
        cli.hello()
        assert cli.command(176, 1, GUIDED) == 0
        assert cli.command(400, 1) == 0
        assert cli.command(22, 0, 0, 0, 0, 0, 0, fig.altitude) == 0
        assert cli.interval(32, 50) == 0
        assert cli.step(25.0) == 0  # climb at TKOFF_SPEED 0.5 m/s
        cli.setpoint(tuple(fig.start()), mask=MASK_POS)
        assert cli.step(5.0) == 0
        cli.drain()
        t0 = cli.last["LOCAL_POSITION_NED"].time_boot_ms
        assert cli.last["LOCAL_POSITION_NED"].z == pytest.approx(-fig.altitude, abs=0.1)
        times, pos = [], []
        wall = time.perf_counter()
        for tk in fig.sample_times():
            cli.setpoint(tuple(fig.position(tk)), tuple(fig.velocity(tk)), tuple(fig.acceleration(tk)))
            m = cli.recv("LOCAL_POSITION_NED", 5.0, lambda m: m.time_boot_ms > (t0 + tk * 1000 + 1))
            assert m is not None
            times.append((m.time_boot_ms - t0) / 1000.0)
            pos.append((m.x, m.y, m.z))
        wall = time.perf_counter() - wall
        # End on a position-only target, then LAND (fact sheet 4.1): touches down and disarms, no crash.
        cli.setpoint(tuple(fig.start()), mask=MASK_POS)
        assert cli.command(176, 1, 9) == 0
        assert cli.step(30.0) == 0
        hb = cli.recv("HEARTBEAT", 5.0)
        assert hb is not None and not hb.base_mode & 128
        assert "Landed, disarming" in cli.texts
        assert not any(t.startswith("Crash") for t in cli.texts)
    t, pos = np.array(times), np.array(pos)
    assert np.allclose(np.diff(t), 0.02, atol=1e-3)
    rms_mav = tracking_rms(t, pos, fig, fig.duration - fig.period, fig.duration)
    rms_local = fly(Copter3D("ardupilot-legacy"), fig).rms_lap2
    print(f"lap-2 RMS over MAVLink {rms_mav:.4f} m, in process {rms_local:.4f} m, 40 s flown in {wall:.1f} s wall")
    assert rms_mav == pytest.approx(rms_local, rel=0.1)
