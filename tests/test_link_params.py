"""A radio-like link: the link shape (bandwidth, buffer, latency, whole-frame loss in bursts), the link emulator
process between our simulator (or ArduCopter SITL) and the tuner, and a parameter download that finishes
through it because it keeps asking while the link makes progress."""

from __future__ import annotations

import os

os.environ["MAVLINK20"] = "1"

import time  # noqa: E402

import pytest  # noqa: E402
from pymavlink.dialects.v20 import ardupilotmega as mavlink  # noqa: E402

from ksbo_mav.errors import VehicleError  # noqa: E402
from ksbo_mav.mav.link import Endpoint, Link  # noqa: E402
from ksbo_mav.mav.params import ParamClient  # noqa: E402
from ksbo_mav.mav.vehicle import Vehicle  # noqa: E402
from ksbo_sim.errors import SimInputError  # noqa: E402
from ksbo_sim.linkemu import split_frames  # noqa: E402
from ksbo_sim.linkproc import LinkEmulator  # noqa: E402
from ksbo_sim.linkshape import LinkShape, pipes  # noqa: E402
from ksbo_sim.process import SimProcess, free_udp_port  # noqa: E402
from link_helpers import check_link_through, realtime_through  # noqa: E402

pytestmark = pytest.mark.timeout(120)
RADIO = "down=4000,up=2000,queue=1024,loss=0.05,latency=0.02,seed=1"


def test_a_shape_is_parsed_checked_and_described() -> None:
    s = LinkShape.parse("down=4000, up=2000,queue=1024,loss=0.05,burst=3,duplex=half")
    assert (s.down, s.up, s.queue, s.loss, s.burst, s.duplex) == (4000, 2000, 1024, 0.05, 3, "half")
    assert "down 4 kB/s, up 2 kB/s, half duplex" in s.describe()
    for bad in ("down=fast", "speed=3", "loss=1.5", "queue=10", "duplex=quarter", "down"):
        with pytest.raises(SimInputError, match="link spec"):
            LinkShape.parse(bad)


def test_a_pipe_paces_frames_at_its_rate_drops_what_overflows_its_buffer_and_loses_at_its_rate() -> None:
    down, _ = pipes(LinkShape(down=1000, queue=200, latency=0.1))
    for _ in range(10):
        down.push(b"x" * 50, now=0.0)  # 500 bytes offered at once into a 200-byte buffer
    assert down.dropped == 6  # 4 fit
    assert down.due(0.149) == [] and len(down.due(0.151)) == 1  # 50 B at 1 kB/s = 0.05 s, then 0.1 s latency
    assert len(down.due(0.301)) == 3 and down.sent_bytes == 200
    lossy, _ = pipes(LinkShape(loss=0.2, seed=3))
    for k in range(5000):
        lossy.push(b"y", now=0.0)
    assert 0.17 < lossy.lost / 5000 < 0.23
    bursty, _ = pipes(LinkShape(loss=0.05, burst=4, seed=3))
    for k in range(5000):
        bursty.push(b"y", now=0.0)
    assert bursty.lost / 5000 > 1.5 * 0.05  # bursts: each loss drags about 3 more with it


def test_frames_are_cut_from_a_stream_with_garbage_between_them() -> None:
    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    a = mav.heartbeat_encode(2, 3, 0, 0, 0).pack(mav)
    b = mav.param_value_encode(b"POS_X_P", 0.15, 9, 28, 3).pack(mav)
    buf = bytearray(b"\x00junk" + a + b + b[:5])
    assert split_frames(buf) == [a, b] and bytes(buf) == b[:5]  # the incomplete frame waits for the rest


def _through(shape: str):
    """(simulator, emulator, the tuner's endpoint): the simulator sends to the emulator, which shapes the link."""
    gport, vport = free_udp_port(), free_udp_port()
    emu = LinkEmulator(f"udpin:127.0.0.1:{vport}", f"udp:127.0.0.1:{gport}", shape)
    sim = SimProcess("--lockstep", out_port=vport)
    return sim, emu, Endpoint("udp", "127.0.0.1", gport)


@pytest.mark.network
@pytest.mark.parametrize("shape", [RADIO, pytest.param("down=1000,up=1000,queue=512,loss=0.25,burst=3,seed=2",
                                                          marks=pytest.mark.slow)])  # ~14 s
def test_every_parameter_arrives_through_a_thin_lossy_link(shape: str) -> None:
    sim, emu, ep = _through(shape)
    said: list[str] = []
    try:
        v = Vehicle.connect(ep, "sim-planar", log=said.append)
        try:
            assert len(v.params.table) == v.params.count > 0
            assert v.params.table["POS_X_P"].value == pytest.approx(0.15, rel=1e-6)
        finally:
            v.close()
    finally:
        sim.stop()
        stats = emu.stop()
    assert stats["down"]["lost"] + stats["down"]["dropped"] > 0  # the link really lost frames on the way
    assert any(line.startswith("parameters: ") and "downloaded in" in line for line in said)


@pytest.mark.network
def test_a_link_that_stops_delivering_gives_up_after_the_stall_budget_with_one_line() -> None:
    """No new index for ``stall_s``: the download ends (not hangs) and says how far it got."""
    sim, emu, ep = _through("down=300,up=2000,queue=64,loss=0.6,seed=4")
    link = Link(ep)
    try:
        link.wait_heartbeat(20.0)
        client = ParamClient(link, "c_cast")
        t0 = time.monotonic()
        with pytest.raises(VehicleError, match=r"parameter download incomplete: \d+ of") as err:
            client.fetch_all(stall_s=1.0)
        assert time.monotonic() - t0 < 30.0 and "\n" not in str(err.value)
    finally:
        link.close()
        sim.stop()
        emu.stop()


@pytest.mark.sitl
@pytest.mark.slow
@pytest.mark.parametrize("ftp", [True, False], ids=["MAVLink FTP", "PARAM protocol"])
def test_arducopter_parameters_arrive_through_a_radio_like_link(ardupilot_sitl, ftp: bool) -> None:
    """About 1350 parameters through 4 kB/s down, 2 kB/s up, a 1 KB buffer and 5 % loss: as one file over MAVLink
    FTP (ArduPilot serves @PARAM/param.pck), or by the PARAM protocol; the same values either way."""
    gport = free_udp_port()
    emu = LinkEmulator(f"tcp:127.0.0.1:{ardupilot_sitl.tcp_port}", f"udp:127.0.0.1:{gport}", RADIO)
    try:
        v = Vehicle.connect(Endpoint("udp", "127.0.0.1", gport), None, param_ftp=ftp)
        try:
            assert len(v.params.table) == v.params.count > 1000
            assert v.params.last_download.path == ("MAVLink FTP" if ftp else "PARAM protocol")
            names = [n for n in ("PSC_POSXY_P", "PSC_NE_POS_P", "PSC_VELXY_P", "WPNAV_SPEED", "FRAME_CLASS")
                     if n in v.params.table]
            assert len(names) >= 3
            for name in names:  # a float and an integer parameter read back one by one: the same value
                assert v.params.table[name].value == pytest.approx(v.params.read(name, timeout=3.0, retries=5))
        finally:
            v.close()
    finally:
        stats = emu.stop()
    assert stats["down"]["lost"] > 0


@pytest.mark.slow
@pytest.mark.network
@pytest.mark.timeout(300)
def test_a_link_too_thin_for_the_mission_is_refused_before_arming_in_one_line(tmp_path) -> None:
    """1 kB/s down with 20 % loss: not even 10 Hz arrives whole. The campaign stops before reading the baseline or
    arming, names the measured and the needed rates and the lower rates it tried, creates no campaign directory
    and leaves every parameter as it was."""
    from mav_tune_helpers import baseline, fresh_read

    from ksbo_mav.cli import main

    sim, emu, ep = realtime_through("down=1000,up=1000,queue=1024,loss=0.2,seed=5")
    try:
        d = tmp_path / "camp"
        import contextlib
        import io

        err = io.StringIO()
        with contextlib.redirect_stderr(err):
            rc = main(["tune", str(d), "--udp", f"127.0.0.1:{ep.port}", "--profile", "sim-planar", "--budget", "2"])
        lines = [ln for ln in err.getvalue().splitlines() if ln.startswith("error: ")]
        assert rc == 2 and len(lines) == 1, err.getvalue()
        assert "link check: the link delivers LOCAL_POSITION_NED" in lines[0] and "needs LOCAL_POSITION_NED at 50 Hz" \
            in lines[0] and "nothing was written to the vehicle" in lines[0] and "tried 25, 20, 10 Hz too" in lines[0]
        assert not d.exists()
        assert fresh_read(sim) == baseline()  # the simulator's gains as it started
    finally:
        sim.stop()
        emu.stop()


@pytest.mark.slow
@pytest.mark.network
@pytest.mark.timeout(240)
def test_a_link_too_thin_for_50_hz_flies_at_the_highest_rate_it_carries() -> None:
    """2 kB/s down: 50 Hz loses half the frames, so the check steps the mission down (setpoints and telemetry)
    to the first rate that arrives nearly whole and leaves a quarter of the link for commands and bursts, says
    so, and keeps the profile's rate in the figures."""
    from ksbo_mav.campaign.mission_rate import HEADROOM, MAX_LOSS_REDUCED, REDUCED_RATES_HZ

    fig, rate, said = check_link_through("down=2000,up=2000,queue=1024,seed=5")
    assert rate in REDUCED_RATES_HZ and fig.reduced_from_hz == 50, said
    flying = [s for s in said if s.startswith("link: flying at")]
    assert flying[-1].startswith(f"link: flying at {rate} Hz instead of 50 Hz") and fig.loss <= MAX_LOSS_REDUCED, said
    assert fig.bytes_per_s <= HEADROOM * 2000, said  # a rate that fills the radio is passed over
    assert fig.rates_hz["LOCAL_POSITION_NED"] >= 0.8 * rate


@pytest.mark.network
def test_a_link_that_carries_the_mission_passes_and_its_figures_are_kept(tmp_path) -> None:
    from ksbo_mav.campaign.layout import CampaignDir
    from ksbo_mav.campaign.mission_rate import check_link, record_link

    sim, emu, ep = realtime_through("down=20000,up=20000,queue=4096,latency=0.01")
    try:
        v = Vehicle.connect(ep, "sim-planar")
        try:
            said: list[str] = []
            fig = check_link(v, said.append, seconds=2.0)
        finally:
            v.close()
    finally:
        sim.stop()
        emu.stop()
    assert fig.rates_hz["LOCAL_POSITION_NED"] >= 40 and fig.bytes_per_s > 2000 and said[0].startswith("link: ")
    d = CampaignDir.at(tmp_path / "c")
    d.root.mkdir()
    record_link(d, fig)
    record_link(d, fig)
    import json

    doc = json.loads((d.root / "link.json").read_text())
    assert len(doc) == 2 and doc[0]["rates_hz"]["LOCAL_POSITION_NED"] >= 40


@pytest.mark.slow
@pytest.mark.network
def test_a_campaign_flies_at_the_rate_asked_and_a_resume_keeps_it(tmp_path) -> None:
    """`--rate 25`: the trials stream setpoints and ask telemetry at 25 Hz, the rate is stored with the campaign
    and a resume flies it again (the profile's mission is otherwise unchanged)."""
    import json

    from mav_tune_helpers import sim_and_endpoint

    from ksbo_mav.cli import main
    from ksbo_mav.mav.tlog import read_tlog
    from ksbo_mav.mav.trajectory import trajectory_from_tlog

    d = tmp_path / "camp"
    with sim_and_endpoint() as (sim, ep):
        assert main(["tune", str(d), "--udp", f"127.0.0.1:{ep.port}", "--profile", "sim-planar", "--budget", "1",
                     "--rate", "25", "--confirm", "0"]) == 0
        assert json.loads((d / "campaign.json").read_text())["mission"]["rate_hz"] == 25
        assert main(["tune", "--resume", str(d), "--udp", f"127.0.0.1:{ep.port}"]) == 0
    for tlog in sorted((d / "trials").glob("trial_*.tlog")):
        _, _, rec = trajectory_from_tlog(read_tlog(tlog))
        assert rec.dt == 40  # ms between setpoints
    assert main(["tune", str(tmp_path / "x"), "--udp", "127.0.0.1:9", "--rate", "30"]) == 2


def test_ksbo_mav_sim_link_puts_the_emulator_between_the_vehicle_and_the_ground_station() -> None:
    import json
    import signal
    import subprocess
    import sys

    port = free_udp_port()
    proc = subprocess.Popen([sys.executable, "-m", "ksbo_mav.cli", "sim", "--udp", "127.0.0.1:0", "--out",
                             f"127.0.0.1:{port}", "--link", "down=4000,up=2000,queue=1024,latency=0.05"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().startswith("ksbo-linkemu ready")
        assert proc.stdout.readline().startswith("ksbo-sim ready")
        v = Vehicle.connect(Endpoint("udp", "127.0.0.1", port), "sim-planar")
        try:
            assert v.params.read("POS_X_P") == pytest.approx(0.15)
        finally:
            v.close()
    finally:
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=20)
    stats = json.loads(err.split("link: ", 1)[1].splitlines()[0])
    assert stats["down"]["frames"] > 10 and stats["up"]["frames"] > 0  # everything went through the radio


def test_ksbo_mav_sim_link_without_one_out_is_one_line() -> None:
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "sim", "--udp", "127.0.0.1:0", "--link", "down=4000"],
                       capture_output=True, text=True, timeout=30)
    assert r.returncode == 2 and "--link needs exactly one --out" in r.stderr and len(r.stderr.splitlines()) == 1
    r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "sim", "--out", "127.0.0.1:9", "--link", "down=x"],
                       capture_output=True, text=True, timeout=30)
    assert r.returncode == 2 and "link spec" in r.stderr
