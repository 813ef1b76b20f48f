"""A pilot who takes over keeps the vehicle: whether the mode changes during a trial or between two trials, the
campaign stops with the reason, the baseline gains go back (verified by a fresh read), and the vehicle is left
armed in the pilot's mode — never landed, never switched back to guided. Our simulator in its own process over
loopback UDP; the "pilot" is a second MAVLink connection that switches the mode (SIM_PILOT_MODE)."""

from __future__ import annotations

import pytest

from mav_tune_helpers import baseline, fresh_read, sim_and_endpoint

from ksbo_mav.campaign import Campaign, CampaignConfig
from ksbo_mav.errors import VehicleError
from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.vehicle import Vehicle

pytestmark = [pytest.mark.network, pytest.mark.timeout(180)]
LOITER = 5  # the simulator numbers its modes as ArduCopter does (GUIDED 4)


def _pilot_switches(sim, after_s: float) -> None:
    """The pilot's switch to LOITER, ``after_s`` s into the next guided flight (0: at once)."""
    other = Vehicle.connect(Endpoint("udpout", "127.0.0.1", sim.port), "sim-planar", sysid=250, compid=190)
    try:
        other.params.set_verified("SIM_FAULT_AFTER", after_s)
        other.params.set_verified("SIM_PILOT_MODE", LOITER)
    finally:
        other.close()


def _mode_and_armed(sim) -> tuple[int, bool]:
    v = Vehicle.connect(Endpoint("udpout", "127.0.0.1", sim.port), "sim-planar", sysid=250, compid=191)
    try:
        hb = v.link.wait_heartbeat(5.0)
        return int(hb.custom_mode), bool(hb.base_mode & 128)
    finally:
        v.close()


def test_a_mode_change_during_a_trial_stops_the_campaign_and_leaves_the_vehicle_to_the_pilot(tmp_path):
    logs: list[str] = []
    with sim_and_endpoint() as (sim, ep):
        _pilot_switches(sim, 5.0)  # 5 s into the baseline trial
        cfg = CampaignConfig(dir=str(tmp_path / "camp"), budget=4, seed=0, prior="none", end="land")
        with pytest.raises(VehicleError, match="pilot changed the mode.*LOITER"):
            Campaign(cfg, ep, log=logs.append).run()
        assert _mode_and_armed(sim) == (LOITER, True)  # not landed: the default --end land does not apply
        assert not any(line.startswith("landing") for line in logs)
        assert any("left to the pilot" in line for line in logs)
        assert fresh_read(sim) == pytest.approx(baseline(), rel=1e-6, abs=1e-7)


@pytest.mark.slow
def test_a_mode_change_between_trials_is_not_undone(tmp_path):
    """ArduPilot's LOITER is the mode a pilot takes over in; switched to it while the optimiser thinks, the vehicle
    stays there (the next trial does not switch it back to GUIDED)."""
    logs: list[str] = []
    with sim_and_endpoint() as (sim, ep):
        def pilot_after_first(event) -> None:
            if event.flight.meta["trial"] == 1:
                _pilot_switches(sim, 0.0)
                # a heartbeat sent after the switch (to both connections): the tuner reads LOITER before its next trial
                assert _mode_and_armed(sim) == (LOITER, True)

        cfg = CampaignConfig(dir=str(tmp_path / "camp"), budget=4, seed=0, prior="none", end="land")
        with pytest.raises(VehicleError, match="switched to LOITER between trials"):
            Campaign(cfg, ep, log=logs.append, progress=pilot_after_first).run()
        assert _mode_and_armed(sim) == (LOITER, True), logs
        assert not any(line.startswith("landing") for line in logs)
        assert fresh_read(sim) == pytest.approx(baseline(), rel=1e-6, abs=1e-7)
