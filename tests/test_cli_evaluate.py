"""`ksbo-mav evaluate` and CLI error handling, run as a real subprocess."""

import json
import subprocess
import sys

import pytest


def run(*args):
    return subprocess.run([sys.executable, "-m", "ksbo_mav.cli", *args], capture_output=True, text=True, timeout=120)


def test_evaluate_json_keys_and_average():
    r = run("evaluate", "--episodes", "3", "--seed", "4", "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    for key in ("P", "JQ", "L", "L_expected", "safe"):
        assert key in out
    assert out["L_expected"] == 600 and out["safe"] is True
    per = [e["P"] for e in out["per_episode"]]
    assert len(per) == 3 and out["P"] == pytest.approx(sum(per) / 3)
    assert 0.15 < out["P"] < 0.25


def test_evaluate_table_and_plot(tmp_path):
    png = tmp_path / "fig.png"
    r = run("evaluate", "--gains", "scg", "--fixed", "--plot", str(png))
    assert r.returncode == 0, r.stderr
    assert "mean" in r.stdout and "safe" in r.stdout
    assert png.stat().st_size > 10_000


def test_evaluate_crash_reports_unsafe():
    r = run("evaluate", "--gains", "0.15,5,0.1,0.5,0,0.2,3e4,0,1e4", "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["safe"] is False and out["P"] < 0 and out["L"] < 600


@pytest.mark.parametrize("args, message", [
    (("--gains", "1,2,3"), "needs 9"),
    (("--gains", "nan,0,0,0,0,0,0,0,0"), "finite"),
    (("--gains=-1,0,0,0,0,0,0,0,0",), "below its minimum"),
    (("--gains", "a,b,c,d,e,f,g,h,i"), "not a number"),
    (("--gains", "bogus"), "no preset"),
    (("--profile", "nope"), "unknown profile"),
    (("--plot", "out.txt"), ".png"),
])
def test_bad_input_gives_one_line_error(args, message):
    r = run("evaluate", *args)
    assert r.returncode == 2
    assert "Traceback" not in r.stderr
    assert message in r.stderr and r.stderr.startswith("error:")


def test_help_lists_commands():
    r = run("--help")
    assert r.returncode == 0 and "evaluate" in r.stdout
