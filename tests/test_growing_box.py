"""The search box that follows the evidence: it starts as the trust region around the baseline and grows towards the
profile's box (the autopilot's documented ranges) where the optimiser's incumbent reaches an edge, every trial still
certified. Unit tests of the box, the optimiser on a function whose optimum lies past the first box, and a real
campaign against our JSBSim copter process whose better gains lie past the first box."""

from __future__ import annotations

import contextlib
import io
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from mav_tune_helpers import fresh_read, short_figure8, sim_and_endpoint

from ksbo_mav import optimize
from ksbo_mav.cli import main
from ksbo_mav.errors import InputError
from ksbo_mav.mav.gains import trial_limits, trust_region
from ksbo_mav.opt.acquisition.growing_box import GrowingBox
from ksbo_mav.profiles import load_profile


def test_box_moves_only_the_edges_the_incumbent_reaches_and_stops_at_the_limits():
    box = GrowingBox(np.array([-0.3, -2.0]), np.array([1.2, 3.0]), step=0.5)
    assert box.update(np.array([0.5, 0.5]), 1) == []  # inside: nothing moves
    moves = box.update(np.array([0.99, 0.0]), 2)  # upper edge of dim 0, lower edge of dim 1
    assert [(m.dim, m.side, m.old, m.new) for m in moves] == [(0, "upper", 1.0, 1.2), (1, "lower", 0.0, -0.5)]
    assert box.update(np.array([1.2, 0.5]), 3) == []  # at its limit: no further
    assert box.contains(np.array([[1.1, -0.4], [1.3, 0.0]])).tolist() == [True, False]
    frozen = GrowingBox(np.array([-1.0]), np.array([2.0]))
    assert frozen.update(np.array([1.0]), 1, free=np.array([False])) == []  # a dimension the search holds


def test_optimiser_reaches_past_the_first_box_safely_and_stays_put_without_limits():
    def f(x):  # optimum at (2.5, 0.5), first box [0, 1]^2
        return float(1.5 - 0.3 * ((x[0] - 2.5) ** 2 + (x[1] - 0.5) ** 2))

    heard: list[dict] = []
    grown = optimize(f, [0.5, 0.5], [[0, 1], [0, 1]], budget=50, method="ksbo-adaptive", seed=0,
                     limits=[[-1, 3], [-1, 3]], on_grow=heard.append)
    assert grown.x[0] > 1.5 and grown.n_unsafe == 0  # half the first box past its edge
    growth = grown.info["box"]["growth"]
    assert heard == growth  # each growth heard as it happened
    assert growth[0]["side"] == "upper" and growth[0]["dim"] == 0 and growth[0]["old"] == pytest.approx(1.0)
    assert grown.info["box"]["bounds"][0][1] >= 2.0
    kept = optimize(f, [0.5, 0.5], [[0, 1], [0, 1]], budget=50, method="ksbo-adaptive", seed=0)
    assert kept.x[0] <= 1.0 and "box" not in kept.info
    same = optimize(f, [0.5, 0.5], [[0, 1], [0, 1]], budget=20, method="ksbo", seed=1, limits=[[0, 1], [0, 1]])
    plain = optimize(f, [0.5, 0.5], [[0, 1], [0, 1]], budget=20, method="ksbo", seed=1)
    np.testing.assert_array_equal(same.X, plain.X)  # limits equal to the bounds: the very same run
    with pytest.raises(InputError, match="limits must contain bounds"):
        optimize(f, [0.5, 0.5], [[0, 1], [0, 1]], budget=5, limits=[[0.2, 1], [0, 1]])


def test_trials_are_checked_against_the_profile_box_when_it_grows_else_the_first_box():
    prof = load_profile("ardupilot-copter")
    base = np.asarray(prof.default, dtype=float)
    lo, hi = trial_limits(prof, base)
    np.testing.assert_array_equal(np.column_stack([lo, hi]), prof.bounds)
    assert prof.bounds[1].tolist() == [0.1, 6.0]  # NE velocity P: ArduPilot's documented range
    first = np.column_stack(trust_region(prof, base))
    assert first[0].tolist() == [0.5, 1.75]  # the first box around the baseline 1.0
    import dataclasses

    fixed = dataclasses.replace(prof, trust_region=dataclasses.replace(prof.trust_region, grow=False))
    np.testing.assert_array_equal(np.column_stack(trial_limits(fixed, base)), first)


def _tune(args: list[str]) -> tuple[int, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(args)
    return rc, err.getvalue() + out.getvalue()


@pytest.mark.slow
@pytest.mark.network
@pytest.mark.timeout(600)
def test_campaign_box_grows_past_the_first_box_safely_and_resumes(tmp_path):
    """ArduCopter's profile on our JSBSim copter, calm, short figure-8: better tracking lies at higher NE gains, past
    the first box around the defaults (NE position P 0.5-1.75 of ArduPilot's 0.5-2; velocity P 1-4 of 0.1-6)."""
    profile = tmp_path / "short.toml"
    shutil.copy(Path(__file__).parents[1] / "params" / "ardupilot-copter.toml", profile)
    short_figure8(profile)
    d = tmp_path / "camp"
    with sim_and_endpoint("--vehicle", "copter3d", "--personality", "ardupilot") as (sim, ep):
        common = ["--udp", f"127.0.0.1:{ep.port}", "--end", "hold"]
        rc, text = _tune(["tune", str(d), *common, "--profile", str(profile), "--budget", "12", "--no-early-stop",
                          "--validation", "off", "--no-onboard-guard", "--json"])
        assert rc == 0, text
        summary = json.loads(text[text.index("\n{") + 1:])
        assert "search box grew after trial" in text
        first = np.asarray(json.loads((d / "campaign.json").read_text())["bounds"])
        grown = np.asarray(summary["box"]["bounds"])
        assert np.all(grown[:, 0] <= first[:, 0]) and np.all(grown[:, 1] >= first[:, 1]) and np.any(grown != first)
        prof = load_profile(str(profile))
        assert np.all(grown[:, 0] >= prof.bounds[:, 0] - 1e-9) and np.all(grown[:, 1] <= prof.bounds[:, 1] + 1e-9)
        journal = [json.loads(line) for line in (d / "journal.jsonl").read_text().splitlines()]
        beyond = [e for e in journal if e["kind"] == "opt" and
                  np.any((np.asarray(e["x"]) > first[:, 1] + 1e-6) | (np.asarray(e["x"]) < first[:, 0] - 1e-6))]
        assert beyond  # trials flew past the first box, reached from certified points
        assert summary["n_unsafe"] == summary["n_aborted"] == summary["n_crashed"] == 0
        names = prof.names
        base = dict(zip(names, prof.default))
        assert fresh_read(sim, names, str(profile)) == pytest.approx(base, rel=1e-6)  # every parameter back
        assert "search box grew after trial" in (d / "report" / "index.html").read_text()

        # Resume across a growth: drop the last two optimiser trials and the result, then --resume.
        lines = (d / "journal.jsonl").read_text().splitlines()
        opt_idx = [i for i, line in enumerate(lines) if json.loads(line)["kind"] == "opt"]
        (d / "journal.jsonl").write_text("\n".join(lines[:opt_idx[-2]]) + "\n")
        (d / "result.json").unlink()
        rc, text = _tune(["tune", "--resume", str(d), *common, "--json"])
        assert rc == 0, text
        assert "differs from the journal" not in text
        again = json.loads(text[text.index("\n{") + 1:])
        assert again["best"]["unused_journal_trials"] == []
        assert again["box"]["growth"][0] == summary["box"]["growth"][0]  # the replay grows the box where it grew
        assert fresh_read(sim, names, str(profile)) == pytest.approx(base, rel=1e-6)
