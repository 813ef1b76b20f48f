"""Lockstep when the simulator answers late: the tuner re-sends a setpoint whose answer has not come within its
wall-clock re-send timeout (a lost packet must not stall the simulator), and the simulator must step a re-sent
setpoint once, not twice. Twice put its clock ahead of the stream (each later setpoint then acted a step late), so
the same gains scored 0.095 m or 0.49 m depending on how loaded the machine was. Real sockets, our simulator in
its own process, the answers made really late (``SIM_DELAY_MS`` above the client's re-send timeout)."""

from __future__ import annotations

import time

import pytest

from mav_tune_helpers import sim_and_endpoint

from ksbo_mav.mav.vehicle import Vehicle

pytestmark = [pytest.mark.network, pytest.mark.timeout(120)]


def test_a_setpoint_resent_while_its_answer_is_late_is_one_step():
    n = 10
    with sim_and_endpoint() as (_sim, ep):
        v = Vehicle.connect(ep)
        try:
            v.setup_streams()
            v.ensure_airborne()
            g, dt = v.guided, v.mission.dt_ms
            here = g.position()
            v.params.set_verified("SIM_DELAY_MS", 150.0)  # every answer comes after the 0.1 s re-send timeout
            sent: list[int] = []
            send = g.send

            def counted(pos, vel=None, acc=None, t_ms=None):  # the real send, counted
                sent.append(t_ms)
                send(pos, vel, acc, t_ms)

            g.send = counted
            stamps: set[int] = set()
            v.link.handlers.append(
                lambda m: stamps.add(int(m.time_boot_ms)) if m.get_type() == "LOCAL_POSITION_NED" else None)
            t0 = g.follow(lambda j: (here, None, None), n, dt, lambda s: None, resend_s=0.1)
            end = time.monotonic() + 1.0
            while time.monotonic() < end:  # answers to re-sends still on their way
                v.link.pump(0.05)
        finally:
            v.close()
    assert len(sent) > n + 1, "no setpoint was re-sent: the condition under test did not happen"
    # the vehicle's time went exactly one step per setpoint: no stamp past the answer to the last one
    assert sorted(s for s in stamps if s > t0) == [t0 + k * dt for k in range(1, n + 2)]
