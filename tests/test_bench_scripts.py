"""The diagnostics under scripts/diag/ (the benchmarks themselves are sweeps: tests/test_bench_runner.py and
test_bench_kinds.py): each starts and explains itself, and reproduces what the notes say it shows; the plant
suite's report (ksbo_bench) calls a plant ahead / level / behind from the per-seed differences and counts the
frozen tables."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = ROOT / "scripts"


def _load(name: str):
    """A script module of scripts/ (not a package; ``diag/x`` for scripts/diag/x.py), imported by path."""
    spec = importlib.util.spec_from_file_location(name.replace("/", "_"), SCRIPTS / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.parametrize(("script", "flag"), [("diag/oracle_ray.py", "--plot"), ("diag/monitor_backup.py", "--n"),
                                              ("diag/gain_slices.py", "--plot"), ("diag/safe_climb.py", "--seeds"),
                                              ("diag/validation_baseline.py", "--repeats"),
                                              ("diag/param_cache_radio.py", "--shape")])
def test_diagnostics_start(script, flag):
    r = subprocess.run([sys.executable, str(SCRIPTS / script), "--help"], capture_output=True, text=True,
                       timeout=120, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    assert flag in r.stdout


def test_paired_comparison_verdicts():
    from ksbo_bench.report import paired

    rng = np.random.default_rng(0)
    recs = []
    for seed in range(12):
        base = {"nominal": 0.9, "gusts": 0.7, "delay 40ms": 0.4}
        noise = {p: rng.normal(0, 0.01) for p in base}
        for method, shift in (("ksbo", {"nominal": 0.05, "gusts": -0.05, "delay 40ms": 0.0}), ("standard", {})):
            for plant, v in base.items():
                jitter = rng.normal(0, 0.01) if plant == "delay 40ms" else 0.0
                recs.append({"method": method, "plant": plant, "seed": seed, "mode": "strict", "n_prior": 36,
                             "budget": 150, "tag": "", "EP": v + noise[plant] + shift.get(plant, 0.0) + jitter,
                             "n_unsafe": 1 if method == "ksbo" else 0, "n_crashed": 0})
    rows = {row[0]: row for row in paired.paired_rows(recs, "ksbo", "standard")}
    assert rows["nominal"][7] == "ahead" and rows["nominal"][4:6] == (12, 0)
    assert rows["gusts"][7] == "behind" and rows["gusts"][2] == pytest.approx(-0.05)
    assert rows["delay 40ms"][7] == "level"
    assert rows["nominal"][8] == "12/0"  # P < 0 flights ksbo / standard
    text = "\n".join(paired.paired_report(recs))
    assert "ahead on 1, level on 1, behind on 1 of 3 plants" in text
    # fewer than 5 common seeds: no row; a tagged run is not a default and is left out
    assert paired.paired_rows(recs[:6 * 4], "ksbo", "standard") == []
    assert paired.paired_report([{**r, "tag": "x"} for r in recs]) == []


def test_best_known_counts_the_frozen_tables():
    from ksbo_bench.report import plants

    frozen = plants.frozen_best()
    assert len(frozen) >= 10 and all(-1.0 <= v <= 1.0 for v, _ in frozen.values())
    assert frozen["delay 40ms"][0] == pytest.approx(0.953) and "record lost" in frozen["delay 40ms"][1]
    # a planar plant's best known is at least the frozen value, the oracle's and the safe climbs' re-flights
    best = plants.best_known([{"plant": "delay 40ms", "EP": 0.4, "method": "ksbo", "mode": "strict", "seed": 0}])
    assert best["delay 40ms"][0] > 0.98 and best["delay 40ms"][1].startswith("safe climb from a0")


def test_safe_climb_steps_only_to_gains_safe_from_every_start():
    climb = _load("diag/safe_climb")
    c = climb.Climb("nominal", 0, lam=6, generations=3, n_random=2)
    rec = c.run(log=lambda s: None)
    assert rec["starts"] == 10 and rec["generations"] == 3 and rec["episodes"] == 10 * (1 + 3 * 6) + 200
    assert rec["minP32"] >= 0 and rec["EP32"] > 0.19  # a0 scores about 0.19; a step is taken only upwards
    path = rec["path"]
    assert path[0][0] == 0 and [p[0] for p in path] == sorted(p[0] for p in path)
    for gen, _, ep, u in path[1:]:  # every accepted point completes from every start
        P = c.evaluate(np.array(u)[None])[0]
        assert P.min() >= 0 and P[:8].mean() == pytest.approx(ep, abs=5e-3)  # (the path keeps u to 4 decimals)


def test_monitor_backup_diag_same_flights_fewer_crashes():
    """The diagnostic flies the same gains from the same starts under both monitors; the attitude-priority backup
    with the stopping-point fence turns most crashes of the old monitor into recovered aborts."""
    diag = _load("diag/monitor_backup")
    c = diag.plant_counts("nominal", 200, seed=3)
    assert c["before"].shape == c["now"].shape == (200,)
    assert (c["before"] == 2).sum() >= 3 * max(1, (c["now"] == 2).sum())
    # the old monitor's completes that the new one stops are few (it trips earlier only when heading out fast)
    assert ((c["before"] == 0) & (c["now"] != 0)).sum() <= 0.05 * (c["before"] == 0).sum()


def test_gain_slices_show_the_pitch_d_cliff_of_pitch_inertia_x05():
    """diag/gain_slices: on pitch inertia ×0.5, lowering ATT_PIT_D alone from a0's 0.25 to 0.075 lifts
    E[P] from the plateau (≈ 0.3) to ≈ 0.9 with no failing start, and at 0 every start fails."""
    slices = _load("diag/gain_slices").slices
    ep, fail = slices("iyy x0.5", [8], np.array([0.0, 0.075, 0.25]))[8]
    assert ep[1] > 0.8 and ep[2] < 0.4 and fail[1] == 0 == fail[2]
    assert fail[0] == 8 and ep[0] < 0


def test_flights_to_90_takes_the_best_flown_gains_and_the_report_counts_what_was_not_reached():
    """The campaign kind: the best-so-far gains after each flight (the baseline and non-ok flights are not
    candidates); the short-campaign page: median / worst flights-to-90 with a run that never got there."""
    from ksbo_bench.kinds.campaign import best_so_far
    from ksbo_bench.report.short_campaign import report

    entries = [{"kind": "opt", "x": [1, 1], "outcome": "ok", "rms": 0.20},
               {"kind": "opt", "x": [2, 1], "outcome": "ok", "rms": 0.15},
               {"kind": "failed", "x": [3, 1], "outcome": "client", "rms": 0.01},
               {"kind": "baseline", "x": [1, 1], "outcome": "ok", "rms": 0.05},
               {"kind": "opt", "x": [4, 1], "outcome": "ok", "rms": 0.12}]
    best = best_so_far(entries, ["a", "b"])
    assert [(k, g["a"], rms) for k, g, rms in best] == [(2, 2, 0.15), (5, 4, 0.12)]

    def run(seed: int, to90: int | None, rec: float) -> dict:
        return {"key": {"vehicle": "ardupilot", "seed": seed, "tune_args": ["--budget", "10"], "label": "default"},
                "flights": {"total": 12}, "run": {"machine": "test", "started": "2026-12-07T00:00:00Z"},
                "safety": {"unsafe": 0, "aborted": 0, "crashed": 0, "interrupted": 1 if to90 is None else 0},
                "result": {"flights_to_90": to90, "share_of_long": 0.9, "cut": 0.5,
                           "reflown": {"baseline": [0.2, 0.2, 0.2], "rec": [rec] * 3, "long": [0.1] * 3}}}

    text = report([run(0, 4, 0.1), run(1, 6, 0.1), run(2, None, 0.15)])
    row = next(x for x in text.splitlines() if x.startswith("| ArduCopter SITL"))
    assert "| 3 | 12 | 6 / not reached |" in row and "0.100 (0.100–0.150)" in row and "| 0 / 0 / 1 |" in row
