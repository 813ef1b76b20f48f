"""The field set-up: ArduCopter SITL at real time behind a SiK-class radio without RADIO_STATUS (the link
emulator's ``sik`` case), MAVProxy on the ground side of the radio, and two clients of MAVProxy: the tuner and a
ground station that asks for its streams when it connects and again every two minutes, as Mission Planner does when
the rates it receives differ from its settings. MAVProxy runs as the tuner's advice says (``--streamrate -1``: it
asks for no streams itself) and passes its clients' stream requests on (``mavfwd_rate``), so the ground station's
requests reach the vehicle. The campaign completes, the tuner says what the ground station does and what to change
there, the ground station keeps its picture (heartbeats, attitude and position throughout), and every parameter is
as the snapshot had it afterwards. (With MAVProxy's default ``streamrate`` 4, re-sent every 15 s, a 2 kB/s radio is
full a third of the time: see docs/links.md.)"""

from __future__ import annotations

import shutil
import subprocess
import sys
import threading
import time
from collections import Counter

import pytest
from conftest import sitl_or_skip
from link_helpers import GroundStation
from sitl_helpers import param_diff, read_all, trials

from ksbo_sim.linkproc import LinkEmulator
from ksbo_sim.process import free_udp_port

pytestmark = [pytest.mark.sitl, pytest.mark.network, pytest.mark.slow, pytest.mark.timeout(2400),
              pytest.mark.skipif(shutil.which("mavproxy.py") is None,
                                 reason="MAVProxy not installed (interop extra: pip install -e '.[interop]')")]
PICTURE = ("HEARTBEAT", "ATTITUDE", "GLOBAL_POSITION_INT")
#: Seconds between the ground station's stream requests while the campaign flies.
ASK_AGAIN_S = 120.0


class Watching(threading.Thread):
    """The ground station's client, pumped in the background: what it received in each 10 s window."""

    def __init__(self, gcs: GroundStation) -> None:
        super().__init__(daemon=True)
        self.gcs, self.windows, self.stop_flag = gcs, [], False

    def run(self) -> None:
        asked = time.monotonic()
        while not self.stop_flag:
            self.gcs.got = Counter()
            if time.monotonic() - asked >= ASK_AGAIN_S:
                self.gcs.ask_for_streams(4)
                asked = time.monotonic()
            self.gcs.pump(10.0)
            self.windows.append(dict(self.gcs.got))


def test_a_campaign_through_a_radio_shared_with_a_ground_station_through_mavproxy(tmp_path):
    sitl = sitl_or_skip("ardupilot", 1)
    router = watching = None
    try:
        radio_port, tool_port, gcs_port = free_udp_port(), free_udp_port(), free_udp_port()
        emu = LinkEmulator(f"tcp:127.0.0.1:{sitl.tcp_port}", f"udp:127.0.0.1:{radio_port}", "sik")
        router = subprocess.Popen(["mavproxy.py", f"--master=udpin:127.0.0.1:{radio_port}",
                                   f"--out=udp:127.0.0.1:{tool_port}", f"--out=udp:127.0.0.1:{gcs_port}",
                                   "--default-modules=link", "--non-interactive", f"--state-basedir={tmp_path}",
                                   "--streamrate=-1", "--cmd=set mavfwd_rate True",
                                   f"--logfile={tmp_path / 'router.tlog'}"],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL)
        gcs = GroundStation(f"udpin:127.0.0.1:{gcs_port}")
        gcs.wait_for_the_router(120.0)
        gcs.ask_for_streams(4)  # on connecting, as Mission Planner does
        watching = Watching(gcs)
        watching.start()
        d = tmp_path / "shared"
        try:
            r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), "--udp", f"127.0.0.1:{tool_port}",
                                "--prior", "none", "--budget", "2", "--confirm", "0", "--validation", "off"],
                               capture_output=True, text=True, timeout=2200)
        finally:
            watching.stop_flag = True
            watching.join(15)
            gcs.conn.close()
            router.terminate()
            router.wait(10)
            stats = emu.stop()
        out = r.stdout + r.stderr
        said = " ".join(out.split())  # the console wraps its lines
        print("\n".join(ln for ln in r.stderr.splitlines() if ln.startswith("link")), stats, watching.windows)
        assert r.returncode == 0, out[-4000:]
        assert "asked it, on this link, to stop" in said  # the streams that fill the radio, whether seen or not
        assert "arrive again though asked down" in said and "set streamrate -1" in said  # the ground station's
        recs = trials(d)
        assert recs and not [rec for rec in recs if rec["outcome"] in ("aborted", "crashed")], recs
        full = watching.windows[1:-1]  # whole windows during the campaign
        pictured = [w for w in full if all(w.get(k, 0) >= 1 for k in PICTURE)]
        assert full and len(pictured) >= 0.9 * len(full), watching.windows
        now, armed = read_all(sitl, "ardupilot-copter")
        assert not armed and not param_diff(d, now)
    finally:
        if router is not None and router.poll() is None:
            router.kill()
        sitl.stop()
