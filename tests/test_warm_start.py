"""`tune --warm-start EARLIER`: a campaign that starts from a finished one's flights, re-flies its recommendation
right after the baseline, and gets back to its result in a few flights; refused (one line, nothing written) for a
campaign of another profile and gain set. Against the planar simulator process over loopback UDP."""

from __future__ import annotations

import contextlib
import io
import json
import shutil

import numpy as np
import pytest

from mav_tune_helpers import baseline, fresh_read, sim_and_endpoint

from ksbo_mav.cli import main

pytestmark = [pytest.mark.network, pytest.mark.timeout(400)]


def _tune(args: list[str]) -> tuple[int, str, dict | None]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main([*args, "--json"])
    text = out.getvalue()
    return rc, err.getvalue() + text, json.loads(text[text.index("{"):]) if rc == 0 else None


def _journal(d) -> list[dict]:
    return [json.loads(line) for line in (d / "journal.jsonl").read_text().splitlines()]


@pytest.mark.slow
def test_warm_start_refits_the_earlier_result_in_a_few_flights_and_refuses_another_gain_set(tmp_path):
    a, b, c = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    with sim_and_endpoint() as (sim, ep):
        common = ["--udp", f"127.0.0.1:{ep.port}", "--end", "hold"]
        rc, text, first = _tune(["tune", str(a), *common, "--budget", "8", "--prior", "local", "--n-prior", "2"])
        assert rc == 0, text
        rc, text, warm = _tune(["tune", str(b), *common, "--warm-start", str(a), "--budget", "4"])
        assert rc == 0, text
        flights = _journal(b)
        assert len(flights) == 5  # baseline, earlier recommendation, 2 optimiser trials, confirmation
        assert [e["kind"] for e in flights] == ["opt", "opt", "opt", "opt", "confirm"]
        assert np.allclose(flights[1]["x"], first["best"]["x"])  # re-flown right after the baseline
        assert "warm start: the earlier recommendation scores P" in text
        assert warm["best"]["P_confirm"] >= first["best"]["P_confirm"] - 0.05
        assert warm["n_unsafe"] == warm["n_aborted"] == warm["n_crashed"] == 0
        assert fresh_read(sim) == pytest.approx(baseline(), rel=1e-6)

        # Another profile's campaign: refused before anything is written.
        other = tmp_path / "other"
        shutil.copytree(a, other)
        settings = json.loads((other / "campaign.json").read_text())
        settings["profile"] = "px4-copter"
        settings["baseline"] = {f"MPC_{k}": v for k, v in settings["baseline"].items()}
        (other / "campaign.json").write_text(json.dumps(settings))
        rc, text, _ = _tune(["tune", str(c), *common, "--warm-start", str(other), "--budget", "4"])
        assert rc != 0
        line = [ln for ln in text.splitlines() if "--warm-start" in ln]
        assert len(line) == 1 and "same profile" in line[0]
        assert not c.exists()
