"""Connection options, an unresponsive vehicle, and `tune --dry-run` (changes nothing)."""

from __future__ import annotations

import pytest

from mav_tune_helpers import baseline, fresh_read, sim_and_endpoint

from ksbo_mav.cli import main
from ksbo_sim.process import free_udp_port
from ksbo_mav.errors import InputError
from ksbo_mav.mav.link import parse_endpoint


def test_endpoint_parsing():
    assert parse_endpoint(udp="127.0.0.1:14550").device == "udpin:127.0.0.1:14550"
    assert parse_endpoint(udpout="10.0.0.2:14555").device == "udpout:10.0.0.2:14555"
    assert parse_endpoint(tcp="localhost:5760").device == "tcp:localhost:5760"
    ep = parse_endpoint(serial="/dev/ttyUSB0:921600")
    assert ep.device == "/dev/ttyUSB0" and ep.baud == 921600
    for kwargs, msg in (({}, "exactly one"), ({"udp": "a:1", "tcp": "b:2"}, "exactly one"),
                        ({"udp": "14550"}, "HOST:PORT"), ({"tcp": "h:x"}, "not a number"),
                        ({"udp": "h:70000"}, "outside"), ({"serial": "/dev/x:fast"}, "baud")):
        with pytest.raises(InputError, match=msg):
            parse_endpoint(**kwargs)


@pytest.mark.network
@pytest.mark.timeout(30)
@pytest.mark.parametrize("reuse", [False, True], ids=["plain", "so_reuseaddr"])
def test_a_port_a_ground_station_listens_on_is_one_line_naming_it_and_the_fix(tmp_path, capsys, reuse):
    """Another program listening on the UDP port (a ground station; MAVProxy sets SO_REUSEADDR, with which the
    tool's bind would succeed and the two would split the vehicle's messages): one line naming the port and the
    router's second output, nothing written."""
    import socket

    gcs = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    if reuse:
        gcs.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    gcs.bind(("127.0.0.1", 0))
    port = gcs.getsockname()[1]
    try:
        assert main(["tune", str(tmp_path / "c"), "--udp", f"127.0.0.1:{port}", "--timeout", "1"]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "Traceback" not in err
        assert f"already listening on port {port}" in err and "--udp 127.0.0.1:14551" in err
        assert not (tmp_path / "c").exists()
    finally:
        gcs.close()


@pytest.mark.network
@pytest.mark.timeout(30)
def test_no_vehicle_is_a_clear_error(tmp_path, capsys):
    port = free_udp_port()
    assert main(["tune", str(tmp_path / "c"), "--udp", f"127.0.0.1:{port}", "--timeout", "1"]) == 2
    err = capsys.readouterr().err
    assert err.strip().startswith("error: no vehicle heartbeat") and "Traceback" not in err
    assert not (tmp_path / "c" / "snapshot").exists()
    assert main(["tune", "--udp", f"127.0.0.1:{port}"]) == 2  # no DIR
    assert main(["restore", str(tmp_path / "none.json"), "--udp", f"127.0.0.1:{port}"]) == 2
    assert "cannot read snapshot" in capsys.readouterr().err
    # a directory without a campaign: the message names where a campaign keeps its snapshot
    assert main(["restore", str(tmp_path), "--udp", f"127.0.0.1:{port}"]) == 2
    err = capsys.readouterr().err
    assert f"{tmp_path / 'snapshot' / 'vehicle.json'} (a campaign's)" in err and len(err.strip().splitlines()) == 1


@pytest.mark.network
@pytest.mark.timeout(60)
def test_dry_run_prints_plan_and_changes_nothing(tmp_path, capsys):
    with sim_and_endpoint() as (sim, ep):
        d = tmp_path / "c"
        assert main(["tune", str(d), "--udp", f"127.0.0.1:{ep.port}", "--dry-run", "--budget", "12"]) == 0
        out = capsys.readouterr().out
        assert "POS_X_P" in out and "12 trials" in out and "nothing was written" in out
        assert not (d / "snapshot").exists() and not (d / "journal.jsonl").exists()
        assert fresh_read(sim) == pytest.approx(baseline(), rel=1e-6, abs=1e-7)


@pytest.mark.network
@pytest.mark.timeout(60)
def test_tcp_connection_preflight_and_read():
    import subprocess
    import sys

    from ksbo_mav.mav.vehicle import Vehicle

    proc = subprocess.Popen([sys.executable, "-m", "ksbo_sim.mavlink", "--tcp", "127.0.0.1:0", "--lockstep"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        assert line.startswith("ksbo-sim ready tcp:"), line
        port = line.split()[2].rsplit(":", 1)[1]
        v = Vehicle.connect(parse_endpoint(tcp=f"127.0.0.1:{port}"))
        try:
            assert v.stack.name == "ksbo-sim" and len(v.params.table) == v.params.count
            assert v.params.read("POS_Z_P") == pytest.approx(0.5)
        finally:
            v.close()
    finally:
        proc.terminate()
        proc.wait(10)
