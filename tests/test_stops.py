"""The pieces a stop leaves behind, without flying: the command that continues a campaign (by how far it got), the
stop record and what the report page says of it, the validation's state in result.json, the bench pilot's RC port,
and the wind a simulator blows at the mission's height."""

from __future__ import annotations

import json

import pytest

from ksbo_mav.campaign.layout import CampaignDir
from ksbo_mav.campaign.report.page import status_rows
from ksbo_mav.campaign.stops import (EXIT, continue_command, next_phase, read_stop, set_validation_state,
                                     write_stop)
from ksbo_mav.campaign.validation_session import ValidationReport
from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.wind_source import simulated_wind
from ksbo_sim.bench_pilot import rc_port_for


def test_the_command_that_continues_follows_how_far_the_campaign_got(tmp_path):
    d = CampaignDir.at(tmp_path / "c")
    ep = Endpoint("udpout", "192.168.1.5", 14550)
    assert next_phase(d) is None  # nothing there
    d.root.mkdir()
    d.config.write_text("{}")
    assert next_phase(d) == "tune"
    assert continue_command(d, ep) == f"ksbo-mav tune --resume {d.root} --udp-out 192.168.1.5:14550"
    d.result.write_text(json.dumps({"best": {}, "validation": {"state": "pending"}}))
    assert next_phase(d) == "validation"
    assert continue_command(d, Endpoint("tcp", "127.0.0.1", 5760)) == f"ksbo-mav validate {d.root} --tcp 127.0.0.1:5760"
    set_validation_state(d, {"state": "complete"})
    assert next_phase(d) is None and json.loads(d.result.read_text())["best"] == {}


def test_a_stop_record_reads_back_and_the_page_says_what_continues(tmp_path):
    d = CampaignDir.at(tmp_path)
    d.config.write_text("{}")
    write_stop(d, "link lost", "ksbo-mav tune --resume X --tcp 127.0.0.1:5760", "tune", EXIT["error"], "Traceback")
    stop = read_stop(d)
    assert stop is not None and stop.reason == "link lost" and stop.exit == 2 and stop.traceback == "Traceback"
    rows = dict(status_rows({"stopped": {"reason": stop.reason, "command": stop.command},
                             "validation": {"state": "incomplete", "reason": "hold not flown (sticks)",
                                            "command": "ksbo-mav validate X --tcp 127.0.0.1:5760"}}))
    assert "link lost" in rows["Stopped"] and "tune --resume X" in rows["Stopped"]
    assert rows["Status"].startswith("tuned; validation incomplete: hold not flown (sticks)")
    assert "flies the rest" in rows["Status"]


def test_the_validation_state_names_what_is_missing_and_what_flies_it():
    cmd = "ksbo-mav validate X --tcp 127.0.0.1:5760"
    assert ValidationReport(skipped="off (--validation off)").state(cmd) == {"state": "skipped",
                                                                             "reason": "off (--validation off)"}
    assert ValidationReport().state(cmd) == {"state": "complete"}
    rep = ValidationReport(stopped="battery: 30 %", not_flown={"hold": "the throttle stick is at 1000 us"})
    assert rep.state(cmd) == {"state": "incomplete", "command": cmd,
                              "reason": "hold not flown (the throttle stick is at 1000 us); stopped: battery: 30 %"}
    assert rep.lines()[-1].startswith("validation incomplete: hold not flown")


def test_the_bench_pilot_finds_an_ardupilot_sitls_rc_port_from_its_tcp_port():
    assert rc_port_for("tcp:127.0.0.1:5763") == 5501
    assert rc_port_for("tcp:127.0.0.1:5772") == 5511
    assert rc_port_for("tcp:127.0.0.1:14550") is None and rc_port_for("udpin:127.0.0.1:14550") is None


@pytest.mark.parametrize(("params", "speed"), [
    ({"SIM_WIND_SPD": 5.0, "SIM_WIND_DIR": 45.0}, 5.0 * (10 / 60) ** 0.5),  # SITL's default square-root profile
    ({"SIM_WIND_SPD": 5.0, "SIM_WIND_DIR": 45.0, "SIM_WIND_T": 1.0}, 5.0),
    ({"SIM_WIND_SPD": 5.0, "SIM_WIND_DIR": 45.0, "SIM_WIND_T": 2.0, "SIM_WIND_T_ALT": 5.0, "SIM_WIND_T_COEF": 0.1},
     5.5),
    ({"SIH_WIND_N": 3.5355, "SIH_WIND_E": 3.5355}, 5.0),
])
def test_a_simulators_wind_at_the_missions_height(params, speed):
    got, frm, how = simulated_wind(params, 10.0)
    assert got == pytest.approx(speed, rel=1e-3) and frm == pytest.approx(45.0, abs=0.01) and how
    assert simulated_wind({"BATT_CAPACITY": 3300.0}, 10.0) is None
