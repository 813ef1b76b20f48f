"""The mission protocol against the simulator's own (its process, loopback UDP): a mission goes up and comes back
item for item, also through a link that loses a fifth of the frames each way; clearing leaves only ArduPilot-style
home; an unsupported frame is refused in one line."""

from __future__ import annotations

import numpy as np
import pytest

from mav_tune_helpers import sim_and_endpoint

from ksbo_mav.errors import VehicleError
from ksbo_mav.mav.mission_transfer import FRAME_GLOBAL_RELATIVE_ALT_INT, MissionItem, MissionTransfer
from ksbo_mav.mav.vehicle import Vehicle

pytestmark = [pytest.mark.network, pytest.mark.timeout(180)]


def _round_trip(*extra: str, timeout_s: float = 1.5) -> None:
    with sim_and_endpoint(*extra) as (sim, ep):
        v = Vehicle.connect(ep)
        try:
            t = MissionTransfer(v.link, timeout_s=timeout_s, attempts=12)
            frame = t.global_frame()
            assert frame.lat0 == pytest.approx(-35.363261) and frame.home_alt == pytest.approx(584.0)
            items = [frame.home_item()] + [frame.waypoint(np.array([k, -k / 2.0, -10.0 - k / 10.0]), accept_m=0.5)
                                           for k in range(12)]
            t.upload(items)
            got = t.download()
            assert len(got) == len(items)
            for a, b in zip(got[1:], items[1:]):
                assert (a.frame, a.command, a.x, a.y, a.param2) == (b.frame, b.command, b.x, b.y, b.param2)
                assert a.z == pytest.approx(b.z, abs=1e-4)
            # the waypoints land where they were meant in the local frame: 1 m north is 1e7 * 1 / R_earth degrees
            assert got[2].x - got[1].x == pytest.approx(1e7 * np.degrees(1.0 / 6378137.0), abs=1)
            t.set_current(3)
            t.clear()
            assert len(t.download()) == 1  # home stays item 0
        finally:
            v.close()


def test_a_mission_goes_up_and_comes_back():
    _round_trip()


def test_a_mission_goes_up_and_comes_back_through_a_lossy_link():
    # (a loopback answer takes milliseconds: a short wait for each keeps the retries quick)
    _round_trip("--loss-in", "0.2", "--loss-out", "0.2", "--seed", "3", timeout_s=0.3)


def test_an_unsupported_frame_is_refused_in_one_line():
    with sim_and_endpoint() as (sim, ep):
        v = Vehicle.connect(ep)
        try:
            bad = MissionItem(1, 16, 0, 1, 0.0, 0.0, 0.0, 0.0, 0, 0, 10.0)  # MAV_FRAME_LOCAL_NED
            ok = MissionItem(FRAME_GLOBAL_RELATIVE_ALT_INT, 16, 0, 1, 0.0, 0.0, 0.0, 0.0, 0, 0, 10.0)
            with pytest.raises(VehicleError, match="^mission upload refused by the vehicle: unsupported frame$"):
                MissionTransfer(v.link).upload([ok, bad])
        finally:
            v.close()
