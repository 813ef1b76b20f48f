"""A real ArduCopter SITL with MAVLink 2 signing set up: without a key the tool stops with one line that names the
key options; with the key (from $KSBO_SIGNING_KEY_FILE) a short campaign flies, every frame the tool sent is signed,
and the key appears nowhere: not in the campaign directory (tlogs, journal, report, snapshot) nor in the output.

Signing is set up as a ground station does it: SETUP_SIGNING sent on SERIAL0 (TCP 5760+10N), the channel
ArduPilot always trusts (the USB port on a real board); ArduPilot stores the key in its own storage area, not in a
parameter. The tool then talks on SERIAL1 (5762+10N), where unsigned commands are ignored."""

from __future__ import annotations

import hashlib
import json
import time

import pytest
from pymavlink import mavutil

from sitl_helpers import tool, trials

pytestmark = [pytest.mark.sitl, pytest.mark.network, pytest.mark.timeout(600)]
PASSPHRASE = "ksbo signing test passphrase"
KEY = hashlib.sha256(PASSPHRASE.encode()).digest()


@pytest.fixture(scope="module")
def signed_sitl(ardupilot_sitl, tmp_path_factory):
    conn = mavutil.mavlink_connection(f"tcp:127.0.0.1:{ardupilot_sitl.tcp_ports[0]}", source_system=255,
                                      source_component=190, autoreconnect=False)
    try:
        assert conn.wait_heartbeat(timeout=30) is not None
        stamp = int((time.time() - 1420070400) * 100_000)
        for _ in range(3):  # a message sent just before the socket closes may never be read
            conn.mav.setup_signing_send(conn.target_system, conn.target_component, list(KEY), stamp)
            conn.recv_match(type="HEARTBEAT", blocking=True, timeout=1.0)
    finally:
        conn.close()
    probe = mavutil.mavlink_connection(f"tcp:127.0.0.1:{ardupilot_sitl.tcp_ports[1]}", source_system=252,
                                       source_component=190, autoreconnect=False)
    try:  # signing is on: the vehicle signs what it sends on the tool's port
        hb = probe.wait_heartbeat(timeout=10)
        assert hb is not None and hb._header.incompat_flags & 1
    finally:
        probe.close()
    key_file = tmp_path_factory.mktemp("key") / "vehicle.key"
    key_file.write_text(PASSPHRASE + "\n")
    return ardupilot_sitl, key_file


def _port_args(sitl) -> list[str]:
    return ["--tcp", f"127.0.0.1:{sitl.tcp_ports[1]}"]


def test_without_the_key_one_line_names_the_key_options(signed_sitl, tmp_path):
    sitl, _ = signed_sitl
    r = tool("tune", str(tmp_path / "c"), *_port_args(sitl), "--dry-run")
    said = " ".join(r.stderr.split())
    assert r.returncode != 0 and "Traceback" not in said
    assert "the vehicle signs its MAVLink traffic (MAVLink 2 signing)" in said
    assert "--signing-key FILE or $KSBO_SIGNING_KEY_FILE" in said
    assert not (tmp_path / "c").exists()


def test_a_wrong_key_is_named_in_one_line(signed_sitl, tmp_path):
    """A key file holding another passphrase: one line says the frames are signed with another key (not a silent
    vehicle, not an unanswered request), and the wrong key is not printed either."""
    sitl, _ = signed_sitl
    wrong = tmp_path / "other.key"
    wrong.write_text("not the vehicle's passphrase\n")
    r = tool("tune", str(tmp_path / "c"), *_port_args(sitl), "--dry-run", "--signing-key", str(wrong))
    lines = r.stderr.strip().splitlines()
    assert r.returncode != 0 and "Traceback" not in r.stderr, r.stderr[-2000:]
    assert lines[-1].startswith("error: ") and "signed with another key than the one from" in lines[-1], lines[-1]
    assert str(wrong) in lines[-1] and "wrong signing key" in lines[-1]
    assert "no vehicle heartbeat" not in r.stderr and "did not answer" not in r.stderr
    other = hashlib.sha256(b"not the vehicle's passphrase").digest()
    assert not any(s in (r.stdout + r.stderr).encode() for s in (other, other.hex().encode(), b"not the vehicle"))
    assert not (tmp_path / "c").exists()


def _signed_frames_from_us(tlog) -> tuple[int, int]:
    """(frames the tool sent, of them signed) in a trial's tlog."""
    log = mavutil.mavlink_connection(str(tlog), dialect="ardupilotmega")
    sent = signed = 0
    while (msg := log.recv_match()) is not None:
        if msg.get_srcSystem() == 245:
            sent += 1
            signed += bool(msg._header.incompat_flags & 1)
    return sent, signed


@pytest.mark.slow  # a whole signed campaign (~23 s); the refusals without or with a wrong key stay in the default run
def test_with_the_key_a_campaign_flies_signed_and_the_key_is_nowhere(signed_sitl, tmp_path, monkeypatch):
    sitl, key_file = signed_sitl
    monkeypatch.setenv("KSBO_SIGNING_KEY_FILE", str(key_file))
    d = tmp_path / "camp"
    # --trial-source ground: the figure-8's setpoints are streamed, so most of what the tool sends is in the tlog
    r = tool("tune", str(d), *_port_args(sitl), "--prior", "none", "--budget", "2", "--confirm", "0", "--json",
             "--trial-source", "ground")
    assert r.returncode == 0, r.stderr[-3000:]
    summary = json.loads(r.stdout[r.stdout.index("{"):])
    recs = trials(d)
    assert summary["n_trials"] == len(recs) >= 2 and all(rec["outcome"] == "ok" for rec in recs)
    sent, signed = _signed_frames_from_us(recs[0]["tlog"])
    assert sent > 1000 and signed == sent

    secrets = [KEY, KEY.hex().encode(), KEY.hex().upper().encode(), PASSPHRASE.encode()]
    files = [p for p in d.rglob("*") if p.is_file()]
    assert any(p.suffix == ".tlog" for p in files)
    for p in files:
        data = p.read_bytes()
        assert not any(s in data for s in secrets), p
    out = (r.stdout + r.stderr).encode()
    assert not any(s in out for s in secrets)
