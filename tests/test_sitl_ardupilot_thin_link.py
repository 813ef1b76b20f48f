"""A radio link the vehicle oversends: ArduCopter SITL at real time (a link's bandwidth is wall-clock bytes per
second) with a ground station's stream rates (REQUEST_DATA_STREAM, every group at 4 Hz, as MAVProxy's
``--streamrate 4`` asks), through the link emulator at 1.2 kB/s each way. The vehicle sends far more than the link
carries, so most frames are lost and each of its many 4 Hz streams arrives at well under once a second: judged by
what arrived, none of them looked worth quieting and the campaign was refused (measured before: LOCAL_POSITION_NED
7.9 Hz at 10 Hz, 66 % of frames lost). The messages of ArduPilot's stream groups are asked down whether they
arrived or not, and the campaign flies at a reduced mission rate, leaving every parameter as the snapshot had
it."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest
from conftest import sitl_or_skip
from pymavlink import mavutil
from sitl_helpers import param_diff, read_all, trials

from ksbo_sim.linkproc import LinkEmulator
from ksbo_sim.process import free_udp_port

pytestmark = [pytest.mark.sitl, pytest.mark.network, pytest.mark.slow, pytest.mark.timeout(1800)]
SHAPE = "down=1200,up=1200,queue=1024,seed=1"


def _ground_station_stream_rates(sitl, hz: int) -> None:
    """What a ground station does on connecting: every stream group at ``hz`` on SERIAL0 (ArduPilot stores the
    rates in its MAVn_* parameters, before the tuner's snapshot)."""
    gcs = mavutil.mavlink_connection(f"tcp:127.0.0.1:{sitl.tcp_port}", source_system=255, source_component=190,
                                     autoreconnect=False)
    try:
        assert gcs.wait_heartbeat(timeout=30) is not None
        for _ in range(3):
            gcs.mav.request_data_stream_send(sitl.sysid, 1, 0, hz, 1)
            time.sleep(0.3)
    finally:
        gcs.close()


def test_a_campaign_through_a_radio_the_vehicle_oversends_flies(tmp_path):
    sitl = sitl_or_skip("ardupilot", 1)
    try:
        _ground_station_stream_rates(sitl, 4)
        gport = free_udp_port()
        emu = LinkEmulator(f"tcp:127.0.0.1:{sitl.tcp_port}", f"udp:127.0.0.1:{gport}", SHAPE)
        d = tmp_path / "thin"
        try:
            r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), "--udp", f"127.0.0.1:{gport}",
                                "--prior", "none", "--budget", "1", "--confirm", "0"],
                               capture_output=True, text=True, timeout=1700)
        finally:
            stats = emu.stop()
        out = r.stdout + r.stderr
        said = " ".join(out.split())  # the console wraps its lines
        print(said[said.find("link: "):said.find("trial: ")], stats)
        assert r.returncode == 0, out[-4000:]
        assert "asked it, on this link, to stop" in said  # its stream groups quieted, whatever arrived
        assert "link: flying at" in said  # a reduced mission rate the link carries
        recs = trials(d)
        assert recs and all(rec["outcome"] == "ok" for rec in recs), [rec["message"] for rec in recs]
        now, armed = read_all(sitl, "ardupilot-copter")
        assert not armed and not param_diff(d, now)  # no stream-rate parameter touched: intervals only
    finally:
        sitl.stop()
