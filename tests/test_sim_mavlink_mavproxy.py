"""MAVProxy (the `interop` extra) connects to the simulator, fetches all parameters (after the MAVFTP NAK
fallback) and sets one; a plain pymavlink client then reads the new value back from the vehicle."""

from __future__ import annotations

import queue
import shutil
import subprocess
import threading
import time

import pytest

from ksbo_sim.testing import Client, SimProcess

pytestmark = [pytest.mark.network, pytest.mark.timeout(90)]


@pytest.mark.skipif(shutil.which("mavproxy.py") is None,
                    reason="MAVProxy not installed (interop extra: pip install -e '.[interop]'; CI installs it)")
def test_mavproxy_fetches_params_and_sets_one(tmp_path):
    sim = SimProcess("--lockstep")
    # Interactive mode on a pipe: --non-interactive would ignore the commands written to stdin.
    mp = subprocess.Popen(["mavproxy.py", f"--master=udpout:127.0.0.1:{sim.port}", f"--state-basedir={tmp_path}",
                           f"--logfile={tmp_path / 'mav.tlog'}", "--default-modules=param,ftp", "--nowait"],
                          stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          bufsize=1)
    lines: queue.Queue[str] = queue.Queue()
    threading.Thread(target=lambda: [lines.put(x) for x in mp.stdout], daemon=True).start()
    seen: list[str] = []

    def wait_for(text: str, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                seen.append(lines.get(timeout=0.2))
            except queue.Empty:
                continue
            if text in seen[-1]:
                return True
        return False

    cli = None
    try:
        assert wait_for("Received ", 40) and "parameters" in seen[-1], "".join(seen)
        mp.stdin.write("param set POS_X_P 0.25\n")
        mp.stdin.flush()
        cli = Client(sim, source_system=254)
        cli.hello()
        value = None
        for _ in range(20):
            value = cli.param_read("POS_X_P").param_value
            if value == pytest.approx(0.25, rel=1e-7):
                break
            time.sleep(0.25)
        assert value == pytest.approx(0.25, rel=1e-7), "".join(seen)
    finally:
        if cli is not None:
            cli.close()
        mp.kill()
        mp.wait(10)
        assert sim.stop() == 0
