"""Nothing lost at a stop, on ArduCopter SITL with the onboard guard (slow: whole campaigns with their validation).

A bench whose simulated transmitter rests with the throttle low (no pilot): the tune flies, its result (result.json,
the report, recommended.param) is written before the validation, ArduCopter's LOITER hold is refused and journalled
as not flown, the steps and the AUTO box are flown, the tune exits 4 saying "tuned; validation incomplete: ...;
`ksbo-mav validate DIR` flies the rest"; with the bench pilot started, that command flies the holds and the result
is complete. And the link cut mid-trial with nobody on the sticks: the guard's LOITER lands and disarms the vehicle;
when the link is back the tuner stops with exit 3, the report written and the command that continues, which then
finishes the campaign. Every parameter ends as the snapshot had it."""

from __future__ import annotations

import json

import pytest

from sitl_helpers import bench_pilot, param_diff, read_all, tool, tune_behind_link, wait_for_trial
from test_validation_campaign import _lines, _profile

pytestmark = [pytest.mark.sitl, pytest.mark.network, pytest.mark.slow, pytest.mark.timeout(1500)]
PROFILE = "ardupilot-copter"


def test_without_a_pilot_the_hold_is_not_flown_and_validate_flies_it_later(ardupilot_sitl, tmp_path):
    d = tmp_path / "c"
    r = tool("tune", str(d), *ardupilot_sitl.cli_args, "--profile", str(_profile(tmp_path)), "--prior", "none",
             "--budget", "3", "--confirm", "1", "--method", "random", "--validation", "quick", timeout=1200)
    text = " ".join(r.stderr.split())
    assert r.returncode == 4, text[-3000:]
    assert "tuned: the result is on disk" in text and "tuned; validation incomplete: hold not flown (" in text
    assert "throttle stick is at 1000 us" in text and f"`ksbo-mav validate {d} --tcp" in text
    flights = _lines(d / "validation.jsonl")
    assert [f["outcome"] for f in flights if f["manoeuvre"] == "hold"] == ["error"]
    mine = [f for f in flights if f["pair"] == "recommendation"]  # (a further candidate may follow: "trial N")
    assert [f["gains"] for f in mine if f["manoeuvre"] == "auto_mission" and f["outcome"] == "ok"] == \
        ["baseline", "recommendation"] * 2
    result = json.loads((d / "result.json").read_text())
    assert result["validation"]["state"] == "incomplete" and (d / "recommended.param").is_file()
    assert "validation incomplete: hold not flown" in (d / "report" / "index.html").read_text()
    now, armed = read_all(ardupilot_sitl, PROFILE)
    assert not armed and not param_diff(d, now)
    pilot = bench_pilot(ardupilot_sitl)
    try:
        r = tool("validate", str(d), *ardupilot_sitl.cli_args, timeout=900)
    finally:
        said = pilot.stop()
    assert r.returncode == 0, (r.stdout + r.stderr)[-3000:]
    assert "bench pilot: airborne" in said and "throttle low" in said, said
    holds = [f for f in _lines(d / "validation.jsonl") if f["manoeuvre"] == "hold" and f["outcome"] == "ok"
             and f["pair"] == "recommendation"]
    assert [f["gains"] for f in holds] == ["baseline", "recommendation"] * 2
    assert json.loads((d / "result.json").read_text())["validation"] == {"state": "complete"}
    now, armed = read_all(ardupilot_sitl, PROFILE)
    assert not armed and not param_diff(d, now)


def test_a_link_cut_with_nobody_on_the_sticks_lands_by_itself_and_the_stop_says_what_continues(ardupilot_sitl,
                                                                                                 tmp_path):
    d = tmp_path / "cut"
    emu, obs, proc, conn = tune_behind_link(ardupilot_sitl, d, "--prior", "none", "--budget", "2", "--confirm", "0",
                                            "--validation", "off")
    gport = conn[1].rsplit(":", 1)[1]
    try:
        wait_for_trial(proc, d, obs, 1, 900)
        obs.pump(1.5)  # into the trial
        emu.cut()
        assert obs.until(lambda: obs.armed is False, 60.0), obs.texts  # the guard's LOITER came down and disarmed
        emu.reconnect()
        out = proc.communicate(timeout=300)[0]
    finally:
        if proc.poll() is None:
            proc.kill()
        obs.close()
    text = " ".join(out.split())
    assert proc.returncode == 3, text[-3000:]
    assert "landed and disarmed by itself while the link was down" in text
    command = f"ksbo-mav tune --resume {d} --udp 127.0.0.1:{gport}"
    assert f"`{command}` continues" in text
    stop = json.loads((d / "stopped.json").read_text())
    assert stop["command"] == command and stop["exit"] == 3 and stop["phase"] == "tune"
    assert "landed and disarmed by itself" in (d / "report" / "index.html").read_text()
    try:
        r = tool(*command.split()[1:], timeout=600)
    finally:
        emu.stop()
    assert r.returncode == 0, r.stderr[-3000:]
    assert not (d / "stopped.json").exists() and (d / "result.json").is_file()
    now, armed = read_all(ardupilot_sitl, PROFILE)
    assert not armed and not param_diff(d, now)
