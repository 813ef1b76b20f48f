"""First-run answers: refused profiles, a closed TCP port and --help each give one clear line, a
non-zero exit and no file; real subprocesses."""

from __future__ import annotations

import socket
import subprocess
import sys

import pytest

from ksbo_mav.errors import VehicleError
from ksbo_mav.mav.link import Endpoint, Link


def run(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "ksbo_mav.cli", *args], capture_output=True, text=True,
                          timeout=120, cwd=cwd)


def closed_tcp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])  # nothing listens once the socket is closed


def one_line_error(r, *words):
    assert r.returncode == 2, (r.stdout, r.stderr)
    err = r.stderr.strip()  # (tune's progress display may leave an empty line before it)
    assert err.startswith("error: ") and "\n" not in err, r.stderr
    assert "Traceback" not in r.stderr
    for w in words:
        assert w in r.stderr


@pytest.mark.parametrize("profile", ["ardupilot-copter", "px4-copter"])
def test_evaluate_refuses_copter_profiles_in_one_line(tmp_path, profile):
    png = tmp_path / "fig.png"
    r = run("evaluate", "--profile", profile, "--plot", str(png), cwd=tmp_path)
    one_line_error(r, profile, "planar", "ksbo-mav tune")
    assert r.stdout == "" and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("profile", ["ardupilot-copter", "px4-copter"])
def test_prior_refuses_copter_profiles_in_one_line(tmp_path, profile):
    r = run("prior", "--profile", profile, "--n", "4", "--out", str(tmp_path / "prior.csv"), cwd=tmp_path)
    one_line_error(r, profile, "planar")
    assert r.stdout == "" and list(tmp_path.iterdir()) == []


def test_tcp_connect_failure_is_one_line_without_pymavlink_retry_noise(tmp_path):
    port = closed_tcp_port()
    r = run("tune", str(tmp_path / "camp"), "--tcp", f"127.0.0.1:{port}", cwd=tmp_path)
    one_line_error(r, f"cannot open tcp 127.0.0.1:{port}", "refused")
    assert "sleeping" not in r.stdout and "refused" not in r.stdout


def test_link_open_on_a_closed_tcp_port_prints_nothing(capsys):
    with pytest.raises(VehicleError, match="cannot open tcp 127.0.0.1"):
        Link(Endpoint("tcp", "127.0.0.1", closed_tcp_port()))
    out = capsys.readouterr()
    assert out.out == "" and out.err == ""


@pytest.mark.parametrize("command", ["tune", "restore", "accept"])
def test_timeout_shows_its_default_and_must_be_positive(command):
    r = run(command, "--help")
    assert r.returncode == 0 and "default: 15" in " ".join(r.stdout.split())
    r = run(command, "DIR", "--tcp", "127.0.0.1:5760", "--timeout", "-1")
    assert r.returncode == 2 and "--timeout" in r.stderr and "positive" in r.stderr


def test_simulator_input_errors_are_one_line_from_both_entry_points():
    one_line_error(run("sim", "--speedup", "-1"), "--speedup must be positive")
    r = subprocess.run([sys.executable, "-m", "ksbo_sim.mavlink", "--personality", "nope"], capture_output=True,
                       text=True, timeout=120)
    one_line_error(r, "unknown personality 'nope'")


def test_simulator_launcher_reports_a_failed_start_in_one_line():
    from ksbo_sim.errors import SimStartError
    from ksbo_sim.process import SimProcess

    with pytest.raises(SimStartError) as exc:
        SimProcess("--personality", "nope")
    assert "did not start" in str(exc.value) and "unknown personality 'nope'" in str(exc.value)
    assert "\n" not in str(exc.value)
