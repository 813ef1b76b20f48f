"""The firmware line: the one table of docs/firmware.md read at connect, the verdict per stack, release and parameter
generation, the warning for a newer release series, and the line on the console of a dry run against our simulator
in each ArduPilot generation and as PX4. PX4's parameter generations from the parameter list."""

from __future__ import annotations

import subprocess
import sys
from importlib import resources
from pathlib import Path
from types import SimpleNamespace

import pytest
from mav_tune_helpers import sim_and_endpoint

from ksbo_mav.errors import InputError
from ksbo_mav.mav.firmware import NOT_VERIFIED, check_firmware, parse_table, table
from ksbo_mav.mav.link_loss import LinkLossPlan
from ksbo_mav.mav.px4_generation import px4_generation, stick_override_words

ROOT = Path(__file__).resolve().parents[1]


def version(major: int, minor: int, patch: int, kind: int = 255) -> int:
    return (major << 24) | (minor << 16) | (patch << 8) | kind


def test_the_tool_reads_the_docs_table():
    packaged = resources.files("ksbo_params").joinpath("firmware.md").read_text(encoding="utf-8")
    assert packaged == (ROOT / "docs" / "firmware.md").read_text(encoding="utf-8")
    rows = table()
    assert {r.stack for r in rows} == {"ardupilot", "px4", "ksbo-sim"}
    assert {(r.firmware, r.parameters) for r in rows if r.stack == "ardupilot"} >= {("4.5", "legacy"),
                                                                                    ("4.6", "legacy"), ("4.7", "new")}


def test_a_malformed_row_is_refused():
    text = "<!-- firmware-table:begin -->\n| px4 | one.two | any | flown | x |\n<!-- firmware-table:end -->"
    with pytest.raises(InputError, match="bad row"):
        parse_table(text)
    with pytest.raises(InputError, match="markers"):
        parse_table("| px4 | 1.15 | any | not verified | x |")


@pytest.mark.parametrize(("stack", "fw", "generation", "verified", "warns"), [
    ("ardupilot", version(4, 7, 0), "new", "checked against source", False),
    ("ardupilot", version(4, 7, 0, 0), "legacy", "flown on SITL here", False),  # the SITL here
    ("ardupilot", version(4, 7, 0, 0), "new", "checked against source", False),  # master after the rename
    ("ardupilot", version(4, 6, 3), "legacy", "checked against source", False),
    ("ardupilot", version(4, 5, 7), "legacy", "checked against source", False),
    ("ardupilot", version(4, 6, 3), "new", NOT_VERIFIED, False),  # 4.6 never had the new names
    ("ardupilot", version(4, 4, 4), "legacy", NOT_VERIFIED, False),
    ("ardupilot", version(4, 8, 0, 0), "new", NOT_VERIFIED, True),
    ("px4", version(1, 15, 4), "", "flown on SITL here", False),
    ("px4", version(1, 19, 0, 0), "", "flown on SITL here", False),
    ("px4", version(1, 17, 2), "", NOT_VERIFIED, False),
    ("px4", version(1, 20, 0, 0), "", NOT_VERIFIED, True),
])
def test_verdict_per_release_and_generation(stack, fw, generation, verified, warns):
    c = check_firmware(stack, fw, generation)
    assert c.verified == verified
    assert bool(c.warning) == warns
    assert c.line.startswith("firmware: ") and "AUTOPILOT_VERSION" in c.line and verified in c.line
    assert "\n" not in c.line + c.warning


def test_px4_generation_from_the_parameter_list():
    v115 = {"MPC_HOLD_DZ": 0.1, "COM_RC_OVERRIDE": 1, "COM_RC_STICK_OV": 30.0}
    main = {"MAN_DEADZONE": 0.1, "MAN_OVERRIDE_SPD": 1.0}
    assert px4_generation(v115).startswith("<= 1.16")
    assert px4_generation({"MAN_DEADZONE": 0.1, "COM_RC_OVERRIDE": 1}).startswith("1.17")
    assert px4_generation(main).startswith("1.18+")
    # 1.15's default COM_RC_OVERRIDE 1 is bit 0 only (auto modes): the sticks do not end OFFBOARD
    assert "off" in stick_override_words(v115)
    both = stick_override_words({**v115, "COM_RC_OVERRIDE": 3})
    assert "COM_RC_STICK_OV" in both and "30 %" in both
    assert "MAN_OVERRIDE_SPD" in stick_override_words(main)
    assert "off" in stick_override_words({"MAN_OVERRIDE_SPD": -1.0})
    failsafes = {"COM_OF_LOSS_T": 1.0, "COM_OBL_RC_ACT": 2, "NAV_DLL_ACT": 0, "COM_DL_LOSS_T": 10}
    old = LinkLossPlan.from_params({n: SimpleNamespace(value=x) for n, x in {**failsafes, **v115}.items()})
    new = LinkLossPlan.from_params({n: SimpleNamespace(value=x) for n, x in {**failsafes, **main}.items()})
    assert "Manual mode" in old.describe() and "COM_RC_OVERRIDE bit 1 clear" in old.describe()
    assert "Stabilized mode" in new.describe() and "MAN_OVERRIDE_SPD" in new.describe()


def _dry_run(tmp_path: Path, *sim_args: str) -> str:
    with sim_and_endpoint(*sim_args) as (_sim, ep):
        r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(tmp_path / "c"), "--udp",
                            f"{ep.host}:{ep.port}", "--dry-run"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    return " ".join((r.stdout + r.stderr).split())  # the console wraps long lines


@pytest.mark.network
@pytest.mark.parametrize(("personality", "says"), [
    ("ardupilot", "firmware: ArduPilot 4.7.0 (AUTOPILOT_VERSION), parameter generation new (PSC_NE_*, PSC_D_*), "
                  "verified: checked against source (docs/firmware.md, row ardupilot 4.7 new)"),
    ("ardupilot-legacy", "firmware: ArduPilot 4.6.0 (AUTOPILOT_VERSION), parameter generation legacy (PSC_POSXY_*, "
                         "PSC_VELZ_*, PSC_ACCZ_*), verified: checked against source (docs/firmware.md, row ardupilot "
                         "4.6 legacy)"),
    ("px4", "firmware: PX4 1.15.0 (AUTOPILOT_VERSION), verified: flown on SITL here (docs/firmware.md, row px4 1.15 "
            "any)"),
])
def test_the_console_says_the_firmware_line_on_our_simulator(tmp_path, personality, says):
    out = _dry_run(tmp_path, "--vehicle", "copter3d", "--personality", personality)
    assert out.count(says) == 2, out[-3000:]  # at connect, and in the plan


def _connect_log(*sim_args: str) -> tuple[str, dict]:
    from ksbo_mav.mav.vehicle import Vehicle

    lines: list[str] = []
    with sim_and_endpoint(*sim_args) as (_sim, ep):
        v = Vehicle.connect(ep, log=lines.append)
        try:
            table = {n: p.value for n, p in v.params.table.items()}
        finally:
            v.close()
    return "\n".join(lines), table


@pytest.mark.network
def test_the_parameter_file_is_asked_for_by_version():
    """PX4 serves @PARAM/param.pck only from 1.19 (PR #28435): a 1.15 is not asked even when it says FTP, a 1.19
    that serves it gives every parameter in one file. No SITL here serves it: our simulator does (``--param-file``),
    in ArduPilot's packed format (PX4's own file was not at hand here to compare)."""
    px4 = ("--vehicle", "copter3d", "--personality", "px4")
    said, old = _connect_log(*px4, "--param-file")
    assert "serves no @PARAM/param.pck" in said and "(PARAM protocol" in said
    said, new = _connect_log(*px4, "--param-file", "--firmware", "1.19.0-dev")
    assert "(MAVLink FTP" in said and "PX4 1.19.0-dev" in said
    assert new == pytest.approx(old)  # the same values either way
    # PX4 main of 2026-08-13 says FTP and answers "file not found": tests/test_sitl_px4_main.py flies it
