"""A slow or lossy link (a radio's queue, a long Wi-Fi path): command waits sized to the measured round trip, the
setpoint stream thinned while the ground radio's buffer fills, the uplink probed through the radio's report, and
heartbeats lost while telemetry still arrives not taken for a lost link. Our simulator in real time, behind the
link emulator where a shape is needed, over loopback UDP."""

from __future__ import annotations

import os

os.environ["MAVLINK20"] = "1"

import time  # noqa: E402

import pytest  # noqa: E402

from ksbo_mav.campaign.mission_rate import check_link  # noqa: E402
from ksbo_mav.errors import LinkLost, VehicleError  # noqa: E402
from ksbo_mav.mav.link import Endpoint  # noqa: E402
from ksbo_mav.mav.vehicle import Vehicle  # noqa: E402
from link_helpers import check_link_through, realtime_through  # noqa: E402
from ksbo_sim.process import SimProcess, free_udp_port  # noqa: E402

CMD_INTERVAL = 511  # SET_MESSAGE_INTERVAL: our simulator acknowledges it
HEARTBEAT_ID = 0


@pytest.mark.slow  # default run: the link check's figures: test_link_params
@pytest.mark.network
@pytest.mark.timeout(180)
def test_command_waits_follow_the_measured_round_trip() -> None:
    sim, emu, ep = realtime_through("down=20000,up=20000,queue=16384,latency=0.8")
    try:
        v = Vehicle.connect(ep, "sim-planar")
        try:
            # One attempt of the default second cannot hear an answer that needs 1.6 s.
            with pytest.raises(VehicleError, match="after 1 attempts of 1.0 s each"):
                v.cmd.command(CMD_INTERVAL, HEARTBEAT_ID, 1_000_000, retries=1)
            said: list[str] = []
            fig = check_link(v, said.append, seconds=2.0)
            assert fig.rtt_ms is not None and fig.rtt_ms > 1500
            assert any(s.startswith("commands: waiting up to") for s in said), said
            v.link.pump(3.0)  # the late answer to the refused attempt arrives and is dropped here
            assert v.cmd.command(CMD_INTERVAL, HEARTBEAT_ID, 1_000_000, retries=1) == 0
        finally:
            v.close()
    finally:
        sim.stop()
        emu.stop()


def _stream_through(shape: str, seconds: float = 5.0) -> tuple[dict, int, list[int | None]]:
    """Setpoints of the mission at 50 Hz for ``seconds`` through the emulator: (its counters, the setpoints the
    stream left out, the txbuf values the tuner saw)."""
    sim, emu, ep = realtime_through(shape)
    seen: list[int | None] = []
    try:
        v = Vehicle.connect(ep, "sim-planar")
        try:
            v.setup_streams()
            m = v.mission
            v.guided.follow(m.setpoint, int(seconds * 1000 / m.dt_ms), m.dt_ms,
                            lambda _s: seen.append(v.guided.radio.txbuf))
            thinned = v.guided.radio.thinned
        finally:
            v.close()
    finally:
        sim.stop()
        stats = emu.stop()
    return stats, thinned, seen


@pytest.mark.slow  # default run: a thin link's rate stepped down: test_link_params
@pytest.mark.network
@pytest.mark.timeout(180)
def test_setpoints_thin_out_when_the_ground_radio_reports_its_buffer_filling() -> None:
    """A 1.5 kB/s uplink with a 1 KB buffer cannot carry 50 Hz setpoints (~3.2 kB/s). Without a radio report every
    setpoint is offered and the buffer drops what overflows; with the ground radio's RADIO_STATUS (as a SiK radio
    sends it) the stream sends every second or fourth setpoint while the buffer is filling, and far fewer are
    dropped."""
    thin = "down=20000,up=1500,queue=1024"
    blind, none_left_out, _ = _stream_through(thin)
    told, left_out, seen = _stream_through(thin + ",radio=1")
    assert none_left_out == 0 and blind["up"]["dropped"] > 50, blind
    assert left_out > 50 and min(x for x in seen if x is not None) < 50, (left_out, seen[-5:])
    assert told["up"]["dropped"] < blind["up"]["dropped"] / 2, (told, blind)



@pytest.mark.slow
@pytest.mark.network
@pytest.mark.timeout(180)
def test_an_uplink_too_thin_for_50_hz_setpoints_is_found_by_the_radios_buffer_and_stepped_down() -> None:
    """The downlink carries everything; the uplink (1.5 kB/s, 1 KB buffer) cannot carry 50 Hz setpoints (~3.3
    kB/s). The downlink figures cannot show it; the ground radio's RADIO_STATUS can: the link check streams
    mission-sized setpoints that the autopilot ignores, sees the radio's buffer fill and steps the rate down."""
    fig, rate, said = check_link_through("down=20000,up=1500,queue=1024,radio=1")
    assert any("fill the ground radio's buffer" in s for s in said), said
    assert fig.reduced_from_hz == 50 and rate < 50 and rate * 65 < 1500, (rate, said)
    assert any(s.startswith(f"link: flying at {rate} Hz instead of 50 Hz") for s in said), said


@pytest.mark.slow  # default run: the lost-link rule: test_mav_trial
@pytest.mark.network
@pytest.mark.timeout(120)
def test_heartbeats_lost_while_telemetry_arrives_are_not_a_lost_link() -> None:
    """Five seconds without a HEARTBEAT (the simulator's SIM_HB_MUTE_S; the other streams go on): the link is not
    lost. Five seconds of silence (SIM_MUTE_S: nothing at all) still is, after the usual timeout."""
    port = free_udp_port()
    with SimProcess(out_port=port):
        v = Vehicle.connect(Endpoint("udp", "127.0.0.1", port), "sim-planar")
        try:
            v.setup_streams()
            v.params.set_verified("SIM_HB_MUTE_S", 5.0)
            longest, t0 = 0.0, time.monotonic()
            while time.monotonic() - t0 < 6.5:
                v.link.pump(0.05)
                longest = max(longest, v.link.heartbeat_age())
                v.guided.check_link()  # never raises: the telemetry keeps coming
            assert longest > 1.2 * v.heartbeat_timeout and v.link.heartbeat_age() < 2.0, longest
            v.params.set_verified("SIM_MUTE_S", 5.0)
            t0 = time.monotonic()
            with pytest.raises(LinkLost, match="no heartbeat from the vehicle"):
                while time.monotonic() - t0 < 6.0:
                    v.link.pump(0.05)
                    v.guided.check_link()
            assert time.monotonic() - t0 < 1.5 * v.heartbeat_timeout + 1.0
        finally:
            v.close()


@pytest.mark.slow  # default run: the quieting: test_stream_quieting, test_link_shared
@pytest.mark.network
@pytest.mark.timeout(180)
def test_the_vehicles_own_streams_are_quieted_before_the_mission_rate_is_lowered_and_put_back_at_the_end() -> None:
    """A vehicle streaming what the campaign does not use at 50 Hz (here SERVO_OUTPUT_RAW and SYSTEM_TIME, asked
    for as another ground station or the autopilot's defaults would) over a link that carries the mission's
    streams alone (about 4.4 kB/s of 6.4): the check stops the simulator's default streams the campaign does not
    use, confirms by sequence numbers that the link now carries what the vehicle sends, and keeps 50 Hz; closing
    the vehicle asks for the simulator's own rates again."""
    from pymavlink.dialects.v20 import ardupilotmega as mavlink

    from ksbo_mav.campaign.mission_rate import check_link
    from ksbo_mav.mav.linkcheck import measure

    sim, emu, ep = realtime_through("down=5400,up=20000,queue=1024,seed=2")
    said: list[str] = []
    try:
        v = Vehicle.connect(ep, "sim-planar")
        try:
            for extra in (mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, mavlink.MAVLINK_MSG_ID_SYSTEM_TIME):
                v.cmd.set_interval(extra, 20_000)
            fig = check_link(v, said.append, seconds=2.0)
            rate = v.mission.rate_hz
        finally:
            v.close()
        v = Vehicle.connect(ep, "sim-planar")  # the streams as the simulator sends them by itself
        try:
            after = measure(v.link, 2.0).rates_hz
        finally:
            v.close()
    finally:
        sim.stop()
        emu.stop()
    asked = next((s for s in said if "asked it, on this link, to stop" in s), "")
    assert "(SYSTEM_TIME, SERVO_OUTPUT_RAW)" in asked and "whether or not they arrived" in asked, said
    assert any("the link carries what the vehicle sends" in s for s in said), said
    assert rate == 50 and fig.reduced_from_hz is None and fig.rates_hz.get("SERVO_OUTPUT_RAW", 0) < 1, said
    assert any(s.startswith("link: asked the vehicle for its own rates of the") for s in said), said
    assert after.get("SERVO_OUTPUT_RAW", 0) > 5 and after.get("SYSTEM_TIME", 0) > 0.5, after  # 10 and 1 Hz
