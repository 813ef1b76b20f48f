"""Nothing lost when a validation flight cannot start: the built-in simulator (JSBSim copter as ArduPilot, lockstep,
its own process over loopback UDP) with its simulated transmitter's throttle resting low (``SIM_RC_THR`` 1000, as
on an ArduCopter SITL bench without a pilot), so the LOITER hold is refused. The tune's result (result.json, the
report, recommended.param) is on disk before the first validation flight; the hold is journalled as not flown with
its reason, the steps and the AUTO box still flown; the console and the report say "tuned; validation incomplete:
...; `ksbo-mav validate DIR` flies the rest", and the exit status is 4 (not a failed tune's 2). (That `validate`
then flies only the missing holds: tests/test_sitl_stops.py, on ArduCopter SITL with the bench pilot.)"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mav_tune_helpers import fresh_read, sim_and_endpoint
from test_validation_campaign import NAMES, _lines, _profile

pytestmark = [pytest.mark.network, pytest.mark.timeout(600)]


def test_a_hold_refused_leaves_the_result_the_other_manoeuvres_and_exit_4(tmp_path):
    d = tmp_path / "c"
    prof = _profile(tmp_path)
    with sim_and_endpoint("--vehicle", "copter3d", "--personality", "ardupilot", "--set", "SIM_RC_THR=1000") \
            as (sim, ep):
        before = fresh_read(sim, NAMES, None)
        conn = ["--udp", f"127.0.0.1:{ep.port}"]
        proc = subprocess.Popen([sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), *conn, "--profile", str(prof),
                                 "--budget", "3", "--method", "random", "--prior", "none", "--no-onboard-guard"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        # The tune's result is written before the first validation flight starts.
        seen_before_validation = None
        while proc.poll() is None:
            if seen_before_validation is None and (d / "result.json").is_file():
                seen_before_validation = not (d / "validation.jsonl").exists()
                pending = json.loads((d / "result.json").read_text())["validation"]
            time.sleep(0.02)
        out, err = proc.communicate()
        text = " ".join(err.split())
        assert proc.returncode == 4, text[-3000:]
        assert seen_before_validation is True and pending["state"] == "pending", pending
        assert (d / "report" / "index.html").is_file() and (d / "recommended.param").is_file()
        flights = _lines(d / "validation.jsonl")
        hold = [f for f in flights if f["manoeuvre"] == "hold"]
        assert len(hold) == 1 and hold[0]["outcome"] == "error" and "throttle stick is at 1000 us" in hold[0]["message"]
        for m in ("steps", "auto_mission"):  # the others flown all the same, A B A B
            assert [f["gains"] for f in flights if f["manoeuvre"] == m] == ["baseline", "recommendation"] * 2
        result = json.loads((d / "result.json").read_text())
        checked = result["validation"]
        assert checked["state"] == "incomplete" and "hold not flown" in checked["reason"], checked
        assert checked["command"] == f"ksbo-mav validate {d} --udp 127.0.0.1:{ep.port}"
        said = "tuned; validation incomplete: hold not flown (the throttle stick is at 1000 us"
        assert said in text and f"`ksbo-mav validate {d} --udp 127.0.0.1:{ep.port}` flies the rest" in text, text
        page = " ".join((d / "report" / "index.html").read_text().split())
        assert "tuned; validation incomplete: hold not flown" in page and "throttle stick is at 1000 us" in page
        assert fresh_read(sim, NAMES, None) == pytest.approx(before, rel=1e-6)  # landed with the baseline
    assert Path(d / "stopped.json").exists() is False
