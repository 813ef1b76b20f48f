"""A ground station sharing the vehicle asks for its streams again after the tuner asked them down: the tuner
notices (the stopped streams arrive again), says what is happening and what to change on the ground station, and
asks them down again, its own streams first; the ground station keeps its picture. Our simulator in real time, on
loopback UDP: in short, a second client of the simulator asking; slow, through a radio the ground station's rates
overfill and a router (MAVProxy, the `interop` extra) between the radio and both clients."""

from __future__ import annotations

import os

os.environ["MAVLINK20"] = "1"

import shutil  # noqa: E402
import subprocess  # noqa: E402
import time  # noqa: E402
from collections import Counter  # noqa: E402

import pytest  # noqa: E402

from ksbo_mav.campaign.mission_rate import check_link  # noqa: E402
from ksbo_mav.mav.link import Endpoint  # noqa: E402
from ksbo_mav.mav.vehicle import Vehicle  # noqa: E402
from link_helpers import GroundStation, realtime_through  # noqa: E402
from ksbo_sim.process import SimProcess, free_udp_port  # noqa: E402

pytestmark = [pytest.mark.network, pytest.mark.timeout(240)]
needs_mavproxy = pytest.mark.skipif(shutil.which("mavproxy.py") is None,
                                    reason="MAVProxy not installed (interop extra: pip install -e '.[interop]')")
def test_a_ground_station_asking_again_is_noticed_explained_and_answered():
    """The watch alone: the tuner asked the simulator's default streams down (as its link check does on a full
    link) and watches; a second client asks for every stream group at 10 Hz, which also resets the mission's
    LOCAL_POSITION_NED to 10 Hz."""
    from ksbo_mav.campaign.mission_rate import watch_streams
    from ksbo_mav.mav.linkcheck import measure, needed_streams
    from ksbo_mav.mav.quieting import quiet_plan

    tool_port = free_udp_port()
    sim = SimProcess(out_port=tool_port)
    said: list[str] = []
    gcs = GroundStation(f"udpout:{sim.host}:{sim.port}")
    try:
        v = Vehicle.connect(Endpoint("udp", "127.0.0.1", tool_port), "sim-planar", log=said.append)
        try:
            v.setup_streams()
            v.streams.ask(quiet_plan(v.stack.name, needed_streams(v.mission.kind)), lead=[])
            v.streams.flush()
            watch_streams(v, measure(v.link, 1.0), said.append)
            gcs.ask_for_streams(10)
            since = time.monotonic()
            seen = _pump_until_answered(v, gcs)
            watch, gcs_s = v.stream_watch.summary(), time.monotonic() - since
        finally:
            v.close()
    finally:
        gcs.conn.close()
        sim.stop()
    noticed = next((s for s in said if "arrive again though asked down" in s), "")
    assert ("SERVO_OUTPUT_RAW" in noticed or "SYSTEM_TIME" in noticed) and "set streamrate -1" in noticed, said
    assert "Mission Planner" in noticed, said
    assert watch["streams_asked_again"] == 1, watch
    assert seen["SERVO_OUTPUT_RAW"] + seen["SYSTEM_TIME"] <= 2, seen  # quiet again
    assert seen["LOCAL_POSITION_NED"] > 60 and seen["SYS_STATUS"] <= 4, seen  # its own rates asserted again
    assert min(gcs.got[k] / gcs_s for k in ("HEARTBEAT", "ATTITUDE", "LOCAL_POSITION_NED")) >= 0.5, gcs.got


def _pump_until_answered(v: Vehicle, gcs: GroundStation, timeout_s: float = 15.0) -> Counter[str]:
    """Pump both clients until the tuner has asked the streams down again and the frames sent before it did have
    drained; returns what the tuner received from the vehicle in the 3 s after that."""
    seen: Counter[str] = Counter()
    v.link.handlers.append(lambda m: seen.update([m.get_type()]) if v.link.is_vehicle(m) else None)
    end = time.monotonic() + timeout_s
    while time.monotonic() < end and not v.stream_watch.asked_again:
        v.link.pump(0.02)
        gcs.pump(0.01)
    while v.streams.busy or time.monotonic() - v.streams.last_sent < 1.0:
        v.link.pump(0.02)
        gcs.pump(0.01)
    seen.clear()
    t0 = time.monotonic()
    while time.monotonic() - t0 < 3.0:
        v.link.pump(0.02)
        gcs.pump(0.01)
    return seen


@needs_mavproxy
@pytest.mark.slow
def test_through_a_radio_and_mavproxy_a_ground_station_asking_again_is_noticed_explained_and_answered(tmp_path):
    """MAVProxy (started with --streamrate -1, so that the second client's requests are the only ones) between
    an emulated 4 kB/s radio and both clients; the ground station asks for every group at 50 Hz before the tuner
    connects (the tuner asks the streams down while connecting) and again after its link check."""
    sim, emu, radio = realtime_through("down=4000,up=20000,queue=1024,seed=3")
    tool_port, gcs_port = free_udp_port(), free_udp_port()
    router = subprocess.Popen(["mavproxy.py", f"--master=udpin:127.0.0.1:{radio.port}",
                               f"--out=udp:127.0.0.1:{tool_port}", f"--out=udp:127.0.0.1:{gcs_port}",
                               "--streamrate=-1", "--default-modules=link", "--non-interactive",
                               f"--state-basedir={tmp_path}", f"--logfile={tmp_path / 'router.tlog'}"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL)
    said: list[str] = []
    gcs = GroundStation(f"udpin:127.0.0.1:{gcs_port}")
    try:
        gcs.wait_for_the_router()
        for _ in range(10):  # on connecting: every group at 50 Hz, four times what the radio carries
            gcs.got.clear()
            gcs.ask_for_streams(50)
            gcs.pump(1.0)
            if gcs.got["SYSTEM_TIME"] > 5:  # (1 Hz by itself)
                break
        v = Vehicle.connect(Endpoint("udp", "127.0.0.1", tool_port), "sim-planar", log=said.append)
        try:
            check_link(v, said.append, seconds=1.5)
            assert any("asked it, on this link, to stop" in s for s in said), said
            assert any("the link carries what the vehicle sends" in s for s in said), said
            gcs.got.clear()
            since = time.monotonic()
            gcs.ask_for_streams(50)  # and again later, as Mission Planner does when the rates it sees differ
            seen = _pump_until_answered(v, gcs)
            watch, rate = v.stream_watch.summary(), v.mission.rate_hz
            gcs_s = time.monotonic() - since
        finally:
            v.close()
    finally:
        gcs.conn.close()
        router.terminate()
        router.wait(10)
        sim.stop()
        emu.stop()
    noticed = next((s for s in said if "arrive again though asked down" in s), "")
    assert ("SERVO_OUTPUT_RAW" in noticed or "SYSTEM_TIME" in noticed) and "set streamrate -1" in noticed, said
    assert "Mission Planner" in noticed, said
    assert watch["streams_asked_again"] >= 1, watch
    assert seen["SERVO_OUTPUT_RAW"] + seen["SYSTEM_TIME"] <= 3, seen  # quiet again
    assert seen["LOCAL_POSITION_NED"] > 1.5 * rate and seen["SYS_STATUS"] <= 6, seen  # the campaign's own rates
    picture = {k: gcs.got[k] / gcs_s for k in ("HEARTBEAT", "ATTITUDE", "LOCAL_POSITION_NED")}
    assert min(picture.values()) >= 0.5, (picture, gcs.got)  # the ground station's picture, a second apart at most


@pytest.mark.slow  # default run: a ground station asking again: the test above
def test_a_ground_station_filling_a_link_the_check_found_clear_is_answered_by_the_loss_it_causes():
    """The check found room (nothing asked down), then a ground station asks every group at 50 Hz: nothing the
    tuner asked down comes back, but the radio fills and the vehicle's frames are lost by sequence number; the watch
    asks the stack's default stream sets down whether or not they arrived, and the loss falls."""
    sim, emu, ep = realtime_through("down=6000,up=20000,queue=1024,seed=5")
    said: list[str] = []
    gcs = GroundStation(f"udpout:{sim.host}:{sim.port}")
    try:
        v = Vehicle.connect(ep, "sim-planar", log=said.append)
        try:
            check_link(v, said.append, seconds=1.5)
            assert not v.streams.asked, said  # a clear link: the check asked nothing down
            gcs.ask_for_streams(50)
            end = time.monotonic() + 20.0
            while time.monotonic() < end and not v.stream_watch.loss_requiets:
                v.link.pump(0.02)
                gcs.pump(0.01)
            while v.streams.busy or time.monotonic() - v.streams.last_sent < 2.0:
                v.link.pump(0.02)
            after = _loss_over(v, 3.0)
            watch, asked = v.stream_watch.summary(), dict(v.streams.asked)
        finally:
            v.close()
    finally:
        gcs.conn.close()
        sim.stop()
        emu.stop()
    line = next((s for s in said if "lost by sequence number over the last" in s), "")
    assert watch["requieted_for_loss"] == 1 and "asked the vehicle to stop or slow" in line, said
    assert asked.get("SERVO_OUTPUT_RAW") == 0 and asked.get("SYSTEM_TIME") == 0, asked  # the stack's table
    assert after < 0.1, (after, said)


def _loss_over(v: Vehicle, seconds: float) -> float:
    """Share of the vehicle's frames lost by sequence number over ``seconds``."""
    seqs: list[int] = []
    v.link.handlers.append(lambda m: seqs.append(m.get_seq()) if v.link.is_vehicle(m) else None)
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        v.link.pump(0.02)
    gaps = sum((b - a - 1) % 256 for a, b in zip(seqs, seqs[1:]))
    return gaps / max(gaps + len(seqs), 1)
