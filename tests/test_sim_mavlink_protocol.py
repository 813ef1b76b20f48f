"""Identity, parameter protocol, commands, robustness and process handling of the MAVLink simulator
(own process, real UDP/TCP sockets on 127.0.0.1, plain pymavlink client)."""

from __future__ import annotations

import math
import os
import random
import signal
import socket
import struct
import subprocess
import sys
import time

import pytest

from ksbo_sim.testing import MASK_POS, Client, SimProcess, running_sim

from ksbo_mav.profiles import load_profile

pytestmark = [pytest.mark.network, pytest.mark.timeout(60)]

CAP_MAVLINK2, CAP_PARAM_ENCODE_C_CAST, CAP_SET_POSITION_TARGET_LOCAL_NED = 8192, 131072, 128


def _download(cli: Client) -> dict[int, object]:
    cli.mav.param_request_list_send(1, 1)
    got: dict[int, object] = {}
    while (m := cli.recv("PARAM_VALUE", 1.0)) is not None:
        got[m.param_index] = m
    return got


def test_heartbeat_and_autopilot_version():
    with running_sim("--lockstep") as (sim, cli):
        hb = cli.hello()
        assert (hb.type, hb.autopilot, hb.system_status) == (2, 0, 3)
        assert hb.get_srcSystem() == 1 and hb.get_srcComponent() == 1 and not hb.base_mode & 128
        assert hb.get_msgbuf()[0] == 0xFD  # MAVLink 2 from the first byte
        for cmd, p1 in ((520, 1), (512, 148)):  # REQUEST_AUTOPILOT_CAPABILITIES, REQUEST_MESSAGE
            assert cli.command(cmd, p1) == 0
            ver = cli.recv("AUTOPILOT_VERSION", 5.0)
            assert ver is not None and ver.vendor_id == 0x4B53 and ver.product_id == 1
            caps = ver.capabilities
            assert caps & CAP_MAVLINK2 and caps & CAP_PARAM_ENCODE_C_CAST and caps & CAP_SET_POSITION_TARGET_LOCAL_NED
        assert cli.command(512, 12345) == 2  # unknown message: DENIED with a reason
        assert cli.command(4242) == 3  # unknown command: UNSUPPORTED
        assert cli.command(22, 0, 0, 0, 0, 0, 0, 1.0) == 2  # takeoff while disarmed: DENIED
        assert "Takeoff: not armed" in cli.texts
        assert cli.command(176, 1, 9) == 0 and cli.command(400, 1) == 2  # LAND is not armable
        assert "Arm: Mode not armable" in cli.texts


def test_param_download_is_complete_and_typed():
    with running_sim("--lockstep") as (sim, cli):
        cli.hello()
        got = _download(cli)
        count = {m.param_count for m in got.values()}
        assert len(count) == 1
        n = count.pop()
        assert sorted(got) == list(range(n))
        names = [got[i].param_id for i in range(n)]
        assert len(set(names)) == n
        prof = load_profile("sim-planar")
        assert names[:9] == prof.names  # the tuned gains first, in profile order
        for i, default in enumerate(prof.default):
            assert got[i].param_type == 9 and got[i].param_value == pytest.approx(default, rel=1e-7)
        by_name = {m.param_id: m for m in got.values()}
        assert {"FENCE_X_MAX", "SIM_PKT_LOSS_IN", "SIM_POS_NOISE", "SIM_LOCKSTEP"} <= set(by_name)
        assert by_name["SIM_PILOT_MODE"].param_type == 6 and by_name["SIM_PILOT_MODE"].param_value == -1.0
        # Read by index answers with that index and name.
        cli.mav.param_request_read_send(1, 1, b"", 3)
        m = cli.recv("PARAM_VALUE", 3.0)
        assert (m.param_index, m.param_id) == (3, names[3])


def test_param_set_echo_readback_and_refusals():
    with running_sim("--lockstep") as (sim, cli):
        cli.hello()
        echo = cli.param_set("POS_X_P", 0.3)
        assert echo.param_value == pytest.approx(0.3, rel=1e-7) and echo.param_index == 0 and echo.param_count > 9
        assert cli.param_read("POS_X_P").param_value == echo.param_value
        # Out of range, non-finite and read-only writes are refused but still echoed with the current value.
        assert cli.param_set("POS_X_P", -1.0).param_value == echo.param_value
        assert any("POS_X_P" in t and "outside" in t for t in cli.texts)
        assert cli.param_set("POS_X_P", math.nan).param_value == echo.param_value
        assert cli.param_set("SIM_LOCKSTEP", 0, ptype=6).param_value == 1.0
        assert "Param write denied: SIM_LOCKSTEP" in cli.texts
        # INT32 values are rounded (C-cast encoding).
        assert cli.param_set("SIM_PILOT_MODE", 4.4, ptype=6).param_value == 4.0
        # Unknown names: silence, and nothing changes.
        before = {m.param_id: m.param_value for m in _download(cli).values()}
        assert cli.param_set("NO_SUCH_PARAM", 1.0, timeout=1.0) is None
        after = {m.param_id: m.param_value for m in _download(cli).values()}
        assert after == before and "NO_SUCH_PARAM" not in after


def test_params_persist_across_restart(tmp_path):
    path = tmp_path / "vehicle.param"
    with running_sim("--lockstep", "--params", str(path)) as (sim, cli):
        cli.hello()
        assert cli.param_set("POS_Z_P", 1.25).param_value == 1.25
        assert cli.param_set("SIM_PKT_LOSS_OUT", 0.5).param_value == 0.5  # fault switches are volatile
    assert "POS_Z_P 1.25" in path.read_text()
    with running_sim("--lockstep", "--params", str(path)) as (sim, cli):
        cli.hello()
        assert cli.param_read("POS_Z_P").param_value == 1.25
        assert cli.param_read("SIM_PKT_LOSS_OUT").param_value == 0.0


def test_ftp_is_answered_with_nak():
    with running_sim("--lockstep") as (sim, cli):
        cli.hello()
        path = b"@PARAM/param.pck"
        req = struct.pack("<HBBBBBBI", 7, 0, 4, len(path), 0, 0, 0, 0) + path  # OpenFileRO
        cli.mav.file_transfer_protocol_send(0, 1, 1, list(req.ljust(251, b"\0")))
        m = cli.recv("FILE_TRANSFER_PROTOCOL", 5.0)
        seq, _, opcode, size, req_opcode = struct.unpack_from("<HBBBB", bytes(m.payload), 0)
        assert (seq, opcode, size, req_opcode, m.payload[12]) == (8, 129, 1, 4, 10)  # NAK FileNotFound


def test_garbage_and_other_system_ids_are_ignored():
    with running_sim("--lockstep") as (sim, cli):
        cli.hello()
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        rng = random.Random(6)
        for _ in range(50):
            sock.sendto(bytes(rng.randrange(256) for _ in range(rng.randrange(1, 300))), (sim.host, sim.port))
        frame = bytearray(cli.mav.param_set_encode(1, 1, b"POS_X_P", 0.9, 9).pack(cli.mav))
        frame[-3] ^= 0xFF  # corrupt the payload: CRC mismatch
        sock.sendto(bytes(frame) + b"\xfd\x09", (sim.host, sim.port))
        sock.close()
        cli.mav.param_set_send(2, 1, b"POS_X_P", 0.8, 9)  # for system 2
        cli.mav.command_long_send(2, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0)
        cli.mav.command_long_send(1, 100, 400, 0, 1, 0, 0, 0, 0, 0, 0)  # another component of this vehicle
        assert cli.recv("COMMAND_ACK", 1.0) is None
        assert cli.param_read("POS_X_P").param_value == pytest.approx(0.15, rel=1e-7)
        assert cli.command(520, 1) == 0 and sim.proc.poll() is None


def test_sigterm_exits_cleanly_and_two_instances_run_at_once():
    base = random.Random(os.getpid()).randrange(20000, 40000)
    sims = [SimProcess("--udp", f"127.0.0.1:{base}", "--instance", str(i), "--lockstep", kind="udp")
            for i in range(2)]
    try:
        ports = [s.port for s in sims]
        assert ports == [base, base + 10]
        for s in sims:
            cli = Client(s)
            assert cli.hello().type == 2
            cli.close()
    finally:
        codes = [s.stop(signal.SIGTERM) for s in sims]
    assert codes == [0, 0]
    outputs = [s.output() for s in sims]
    assert all("ksbo-sim stopped" in err for _, err in outputs)
    assert all("Traceback" not in out + err for out, err in outputs)


def test_tcp_server():
    with running_sim("--lockstep", kind="tcp") as (sim, cli):
        assert cli.hello().type == 2
        assert cli.param_read("ATT_PIT_D").param_value == 10000.0


@pytest.mark.parametrize("argv, needle", [
    (["--udp", "nonsense"], "expected HOST:PORT"),
    (["--personality", "betaflight"], "unknown personality"),
    (["--vehicle", "blimp"], "unknown vehicle"),
    (["--set", "NOPE=1"], "unknown parameter NOPE"),
    (["--set", "POS_X_P=-3"], "outside"),
])
def test_cli_errors_are_one_line(argv, needle):
    r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "sim", *argv], capture_output=True, text=True,
                       timeout=30)
    assert r.returncode == 2 and needle in r.stderr and "Traceback" not in r.stderr


def test_streams_rates_and_legacy_request_data_stream():
    """SET_MESSAGE_INTERVAL sets a rate on the simulated clock; a later REQUEST_DATA_STREAM(ALL) overrides it,
    as ArduPilot does (fact sheet 1.5 pitfall). Housekeeping streams are present."""
    with running_sim("--lockstep") as (sim, cli):
        cli.hello()
        assert cli.interval(32, 50) == 0
        cli.drain()
        count = []
        cli.conn.message_hooks.append(lambda conn, m: count.append(m.time_boot_ms)
                                      if m.get_type() == "LOCAL_POSITION_NED" else None)
        assert cli.step(1.0) == 0
        assert len(count) == 50 and count[-1] - count[0] == 980  # one per 20 ms of simulated time
        for kind in ("SYS_STATUS", "SYSTEM_TIME", "ATTITUDE", "SERVO_OUTPUT_RAW", "ACTUATOR_OUTPUT_STATUS"):
            assert kind in cli.last
        cli.mav.request_data_stream_send(1, 1, 0, 4, 1)
        cli.param_read("POS_X_P")  # a round trip, so the stream request has been handled
        count.clear()
        assert cli.step(1.0) == 0
        assert len(count) == 4
        assert cli.interval(32, -1) == 0  # -1 disables the stream
        count.clear()
        assert cli.step(1.0) == 0
        assert count == []


def test_out_address_receives_without_talking_first():
    """--out HOST:PORT: a ground station that only listens (as QGC on 14550) still gets the vehicle."""
    listener = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    listener.bind(("127.0.0.1", 0))
    listener.settimeout(10.0)
    sim = SimProcess("--out", f"127.0.0.1:{listener.getsockname()[1]}")
    try:
        data, addr = listener.recvfrom(65535)
        assert data[0] == 0xFD and data[7:10] == b"\x00\x00\x00"  # MAVLink 2 HEARTBEAT (msgid 0)
        assert addr[1] == sim.port
    finally:
        listener.close()
        assert sim.stop() == 0


def test_lockstep_slower_than_real_time_still_heartbeats_every_wall_second():
    """A client stepping slowly (here 4 steps per wall second, as a lossy link's re-sends make it) keeps getting a
    HEARTBEAT each wall second: a ground station's wall-clock heartbeat timeout must measure the link, not the
    step rate (the simulated clock's own 1 Hz heartbeat would come every 12.5 wall seconds)."""
    with running_sim("--lockstep") as (sim, cli):
        cli.hello()
        cli.drain()
        beats, t_end = 0, time.monotonic() + 4.0
        while time.monotonic() < t_end:
            cli.setpoint((0.0, 0.0, -1.0), mask=MASK_POS)  # one 20 ms step, used or not
            deadline = time.monotonic() + 0.25
            while (m := cli.recv(["HEARTBEAT", "LOCAL_POSITION_NED"], max(0.0, deadline - time.monotonic()))):
                beats += m.get_type() == "HEARTBEAT"
        assert beats >= 3


def test_a_chatty_simulator_keeps_answering_because_its_pipes_are_drained(tmp_path):
    """SimProcess reads the child's stdout and stderr: a simulator whose parameter file cannot be written warns on
    every changed value, and 1000 warnings (~120 KB, more than a pipe holds) must not block it; the last lines are
    kept for ``output()``."""
    path = tmp_path / "sim.parm"
    with running_sim("--lockstep", "--params", str(path)) as (sim, cli):
        cli.hello()
        path.unlink(missing_ok=True)
        path.mkdir()  # a directory where the file was: every save now fails with a warning
        for i in range(1000):  # each answered write of a changed value warns (~120 bytes)
            assert cli.param_set("POS_X_P", 0.15 + 1e-4 * (i % 2 + 1)) is not None, f"no answer to write {i + 1}"
    _, err = sim.output()
    assert err.count("cannot write") >= 990
