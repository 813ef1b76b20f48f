"""What the link check asks the vehicle to stop on a full link: every message of the stack's default stream sets
that the campaign does not use, whatever arrived; never a message the campaign reads. Pure functions over the
tables (no vehicle)."""

from __future__ import annotations

import pytest

from ksbo_mav.mav.linkcheck import GROUND_PICTURE, NEEDED, LinkFigures, needed_streams
from ksbo_mav.mav.quieting import pace_for, quiet_plan
from ksbo_mav.mav.stream_sets import all_messages, default_streams, group_of, message_id


@pytest.mark.parametrize("stack", ["ardupilot", "px4", "ksbo-sim"])
def test_every_message_of_every_table_has_a_mavlink_id(stack):
    names = all_messages(stack)
    assert names and [n for n in names if message_id(n) is None] == []


def test_the_issue_case_an_overfilled_link_where_only_timesync_arrived_still_stops_the_streams_that_fill_it():
    """Measured through a radio the vehicle overfilled: 90 % of its frames lost, and of the streams the campaign
    does not use only TIMESYNC happened to arrive. The plan does not depend on that."""
    fig = LinkFigures(seconds=3.0, bytes_per_s=1400.0, loss=0.9,
                      rates_hz={"LOCAL_POSITION_NED": 4.0, "ATTITUDE": 4.0, "TIMESYNC": 0.4, "HEARTBEAT": 0.3})
    needed = needed_streams("figure8-h")
    plan = quiet_plan("ardupilot", needed, fig)
    for name in ("RAW_IMU", "SCALED_PRESSURE", "AHRS", "AHRS2", "SIMSTATE", "EKF_STATUS_REPORT", "VIBRATION",
                 "SYSTEM_TIME", "SERVO_OUTPUT_RAW", "NAV_CONTROLLER_OUTPUT", "MEMINFO", "POWER_STATUS"):
        assert plan[name] == 0.0, name  # stopped, though never seen
    picture = {n: hz for n, hz in GROUND_PICTURE.items() if n != "HOME_POSITION"}  # ArduPilot: sent on request
    assert {n: plan[n] for n in picture} == picture  # a ground station keeps its picture, slowly
    assert not set(plan) & needed  # nothing the campaign reads
    assert "TIMESYNC" not in plan  # the answers to the check's own requests: no stream to slow
    groups = {group_of("ardupilot", n) for n, hz in plan.items() if hz == 0 and group_of("ardupilot", n)}
    assert groups == {"RAW_SENS", "EXT_STAT", "RC_CHAN", "EXTRA1", "EXTRA3", "PARAMS", "ADSB"}


def test_the_planar_task_keeps_its_actuator_stream_and_the_picture_can_be_slowed_further():
    assert "ACTUATOR_OUTPUT_STATUS" not in quiet_plan("ksbo-sim", needed_streams("figure8-xz"))
    assert quiet_plan("ksbo-sim", needed_streams("figure8-h"))["ACTUATOR_OUTPUT_STATUS"] == 0.0
    slow = quiet_plan("px4", NEEDED, picture_scale=0.2)
    assert slow["GLOBAL_POSITION_INT"] == pytest.approx(0.2) and slow["HIGHRES_IMU"] == 0.0
    assert "PARAM_VALUE" in default_streams("ardupilot")["PARAMS"] and "PARAM_VALUE" not in slow


def test_commands_are_paced_to_half_what_the_link_carried_down():
    assert pace_for(LinkFigures(seconds=3, bytes_per_s=900.0)) == pytest.approx(10.0)
    assert pace_for(LinkFigures(seconds=3, bytes_per_s=50.0)) == 5.0
    assert pace_for(None) == 40.0
