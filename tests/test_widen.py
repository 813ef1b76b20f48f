"""Widening the search box (`tune --widen`): the bound a recommendation ends on moves out stepwise, never past the
gain's documented range, reached through the optimiser's own safe set; journalled, so a resumed campaign replays
the same boxes. Unit tests of the box arithmetic, and a real campaign against the planar simulator process with a
profile whose box ends below the optimum."""

from __future__ import annotations

import contextlib
import io
import json
import re
from pathlib import Path

import numpy as np
import pytest

from mav_tune_helpers import baseline, fresh_read, sim_and_endpoint

from ksbo_mav.campaign.layout import CampaignDir
from ksbo_mav.campaign.widen import Move, WidenStep, append_step, box_profile, next_box, read_steps
from ksbo_mav.cli import main
from ksbo_mav.errors import InputError
from ksbo_mav.profiles import load_profile

NAMES = ["a", "b"]


def test_next_box_moves_only_touched_bounds_and_stops_at_the_documented_range():
    bounds = np.array([[0.0, 1.0], [2.0, 4.0]])
    limits = np.array([[0.0, 1.6], [1.0, 10.0]])
    new, moves = next_box(np.array([1.0, 3.0]), None, bounds, limits, NAMES, 0.5)
    assert new.tolist() == [[0.0, 1.5], [2.0, 4.0]]
    assert moves == [Move("a", "upper", 1.0, 1.5, 1.6)]
    new, moves = next_box(np.array([1.5, 2.0]), None, new, limits, NAMES, 0.5)
    assert new.tolist() == [[0.0, 1.6], [1.0, 4.0]]  # capped at 1.6; b's lower bound 2 -> 1 (its range ends there)
    assert [m.side for m in moves] == ["upper", "lower"]
    assert "documented range ends there" in moves[1].message()
    same, none = next_box(np.array([1.6, 3.0]), None, new, limits, NAMES, 0.5)
    assert none == [] and same.tolist() == new.tolist()


def test_next_box_follows_the_best_flown_trial_too():
    bounds = np.array([[0.0, 1.0], [2.0, 4.0]])
    limits = np.array([[0.0, 2.0], [1.0, 10.0]])
    _, moves = next_box(np.array([0.5, 3.0]), np.array([0.5, 4.0]), bounds, limits, NAMES, 0.25)
    assert moves == [Move("b", "upper", 4.0, 4.5, 10.0)]


def test_box_profile_checks_trials_against_the_wider_box():
    from ksbo_mav.mav.gains import trust_region

    prof = load_profile("ardupilot-copter")
    bounds = np.array([[0.5, 2.0], [1.0, 5.0], [0.1, 1.0], [0.0, 0.5], [1.0, 2.5], [2.0, 8.0]])
    wide = box_profile(prof, bounds)
    lo, hi = trust_region(wide, prof.default)
    assert np.allclose(np.column_stack([lo, hi]), bounds)
    wide.check_gains(np.array([1.0, 4.8, 1.0, 0.25, 1.0, 5.0]))
    with pytest.raises(InputError):
        prof.check_gains(np.array([1.0, 4.8, 1.0, 0.25, 1.0, 5.0]))


def test_steps_are_journalled_and_a_half_written_last_line_is_dropped(tmp_path):
    d = CampaignDir.at(tmp_path)
    step = WidenStep(1, 5, [[0.0, 1.5]], [Move("a", "upper", 1.0, 1.5, 2.0)])
    append_step(d, step)
    with open(tmp_path / "widen.jsonl", "a") as fh:
        fh.write('{"step": 2, "after')
    assert read_steps(d) == [step]


def test_documented_range_must_contain_the_box(tmp_path):
    src = (Path(__file__).parents[1] / "params" / "sim-planar.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(src.replace("default = 0.15\n", "default = 0.15\nrange_max = 0.5\n", 1))
    with pytest.raises(InputError, match="documented"):
        load_profile(str(bad))


def edge_profile(dst: Path, extra_tr: str = "") -> None:
    """sim-planar with POS_X_P's box 0.10-0.15 (P keeps rising to about 0.4) but its documented range up to 1.0, and
    every other gain held within 1 % of its default; widening by the box's width per step, 4 trials each."""
    src = Path(__file__).parents[1] / "params" / "sim-planar.toml"

    def narrow(block: str) -> str:
        name = re.search(r'name = "(\w+)"', block).group(1)
        default = float(re.search(r"\ndefault = ([0-9.eE+-]+)", block).group(1))
        lo, hi = (0.10, 0.1500001) if name == "POS_X_P" else (default * 0.99, default * 1.01) if default else (0, 1e-3)
        block = re.sub(r"\nmin = [0-9.eE+-]+", f"\nmin = {lo!r}", block)
        block = re.sub(r"\nmax = [0-9.eE+-]+", f"\nmax = {hi!r}", block)
        return block.replace("\ndefault", "\nrange_max = 1.0\ndefault", 1) if name == "POS_X_P" else block

    head, *gains = src.read_text().split("[[gains]]")
    text = head + "".join("[[gains]]" + narrow(g) for g in gains)
    dst.write_text(text.replace("[trust_region]\n", "[trust_region]\nwiden_step = 1.0\nwiden_trials = 4\n"
                                f"widen_steps = 3\n{extra_tr}", 1))


def baseline_x() -> list[float]:
    return list(baseline().values())


def _tune(args: list[str]) -> tuple[int, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(args)
    return rc, err.getvalue() + out.getvalue()


@pytest.mark.slow
@pytest.mark.network
@pytest.mark.timeout(400)
def test_widen_reaches_past_the_original_bound_safely_and_resumes(tmp_path):
    profile = tmp_path / "edge.toml"
    edge_profile(profile)
    d = tmp_path / "camp"
    with sim_and_endpoint() as (sim, ep):
        common = ["--udp", f"127.0.0.1:{ep.port}", "--end", "hold"]
        rc, text = _tune(["tune", str(d), *common, "--profile", str(profile), "--budget", "4", "--prior", "local",
                          "--n-prior", "2", "--widen", "--json"])
        assert rc == 0, text
        summary = json.loads(text[text.index("\n{") + 1:])
        # The box-edge note, then the widening, on the console.
        assert "widened: POS_X_P upper bound 0.15 -> 0.175" in text
        steps = read_steps(CampaignDir.at(d))
        assert steps and steps[0].moves[0].name == "POS_X_P"
        assert steps[0].bounds[0][1] == pytest.approx(0.175, rel=1e-5)
        journal = [json.loads(line) for line in (d / "journal.jsonl").read_text().splitlines()]
        beyond = [e for e in journal[steps[0].after_opt:] if e["kind"] == "opt" and e["x"][0] > 0.1505]
        assert beyond  # trials flew beyond the original bound, grown from the recommendation by the safe set
        assert all(abs(a - b) <= 0.011 * abs(b) + 1e-3 for e in beyond for a, b in zip(e["x"][1:], baseline_x()[1:]))
        assert summary["n_unsafe"] == summary["n_aborted"] == summary["n_crashed"] == 0
        assert all(e["P"] >= 0 for e in journal)
        assert fresh_read(sim) == pytest.approx(baseline(), rel=1e-6)  # every parameter back
        page = (d / "report" / "index.html").read_text()
        assert "widened: POS_X_P upper bound 0.15" in page

        # Resume across a widening step: drop the last two optimiser trials and the result, then --resume.
        lines = (d / "journal.jsonl").read_text().splitlines()
        opt_idx = [i for i, line in enumerate(lines) if json.loads(line)["kind"] == "opt"]
        (d / "journal.jsonl").write_text("\n".join(lines[:opt_idx[-2]]) + "\n")
        (d / "result.json").unlink()
        rc, text = _tune(["tune", "--resume", str(d), *common, "--json"])
        assert rc == 0, text
        assert "differs from the journal" not in text
        assert len(read_steps(CampaignDir.at(d))) == len(steps)  # the same boxes, not widened again
        again = json.loads(text[text.index("\n{") + 1:])
        assert again["best"]["unused_journal_trials"] == []
        assert fresh_read(sim) == pytest.approx(baseline(), rel=1e-6)
