"""A real PX4 SITL: before flying, the tool reads PX4's link-loss failsafes and says what they will do (two settings,
two texts), and refuses a link away from the vehicle unless the pilot accepts the risk.

Every SITL link is loopback, which the rule counts as beside the vehicle. The remote link is made the way a user
meets one: the link emulator (``ksbo_sim.linkemu``) runs as a SiK telemetry radio pair between the SITL and the
tool, and its ground radio reports itself with RADIO_STATUS, exactly the evidence the rule reads on a real radio.
(``--link-is-radio`` would only test that a flag is obeyed.) The SITL comes from the ``px4_sitl`` fixture, on an
instance number claimed machine-wide (``ksbo_sim.sitl_instances``)."""

from __future__ import annotations

import pytest

from ksbo_sim.linkproc import LinkEmulator
from ksbo_sim.process import free_udp_port
from sitl_helpers import tool

pytestmark = [pytest.mark.sitl, pytest.mark.network, pytest.mark.timeout(600)]


def _said(r) -> str:
    return " ".join((r.stdout + r.stderr).split())  # the console wraps long lines


def _set(sitl, **values) -> None:
    for name, value in values.items():
        assert sitl.set_param(name, value, int32=isinstance(value, int)) == pytest.approx(value)


def test_the_failsafes_are_read_and_said_before_flying(px4_sitl, tmp_path):
    _set(px4_sitl, COM_OF_LOSS_T=2.5, COM_OBL_RC_ACT=4, NAV_DLL_ACT=0)
    r = tool("tune", str(tmp_path / "a"), *px4_sitl.cli_args, "--dry-run")
    said = _said(r)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "PX4 leaves OFFBOARD 2.5 s after the last setpoint (COM_OF_LOSS_T) for Land mode (COM_OBL_RC_ACT 4)" in said
    assert "data-link-loss failsafe is off (NAV_DLL_ACT 0)" in said
    assert "The trial's gains stay on the vehicle until the link returns" in said
    assert "The tool runs beside the vehicle" in said

    _set(px4_sitl, COM_OF_LOSS_T=1.0, COM_OBL_RC_ACT=0, NAV_DLL_ACT=2, COM_DL_LOSS_T=12)
    said = _said(tool("tune", str(tmp_path / "b"), *px4_sitl.cli_args, "--dry-run"))
    assert "1 s after the last setpoint (COM_OF_LOSS_T) for Position mode (COM_OBL_RC_ACT 0) with an RC " \
           "transmitter connected, else Return mode" in said
    assert "after 12 s without a ground station's heartbeat (COM_DL_LOSS_T) it switches to Return mode " \
           "(NAV_DLL_ACT 2)" in said
    assert "Land mode" not in said


def test_a_radio_link_is_refused_unless_the_risk_is_accepted(px4_sitl, tmp_path):
    ground = free_udp_port()
    # PX4 sends its API link to udp_port: the emulator takes that port as the vehicle's radio, the tool listens
    # behind the ground radio.
    with LinkEmulator(f"udpin:127.0.0.1:{px4_sitl.udp_port}", f"udp:127.0.0.1:{ground}", "radio=1"):
        r = tool("tune", str(tmp_path / "a"), "--udp", f"127.0.0.1:{ground}", "--dry-run", "--timeout", "30")
        said = _said(r)
        assert r.returncode != 0
        assert "refused: a telemetry radio reports itself on the link (RADIO_STATUS)" in said
        assert "--accept-link-loss-risk" in said and "Traceback" not in said
        assert "PX4 leaves OFFBOARD" in said  # what would happen is said before the refusal

        r = tool("tune", str(tmp_path / "b"), "--udp", f"127.0.0.1:{ground}", "--dry-run", "--timeout", "30",
                 "--accept-link-loss-risk")
        assert r.returncode == 0, r.stderr[-2000:]
        assert "flying anyway (--accept-link-loss-risk)" in _said(r)
