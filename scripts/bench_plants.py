"""Benchmark: safe BO over the plant suite — the planar task (nominal + variants, with monitor or
strict), the JSBSim copter in both personalities (in process) and the ArduCopter / PX4 SITLs (full campaigns).

One process, BLAS pinned to one thread; each run appends one JSON line to ``--out`` (so partial results survive
and runs can be added later), ``report`` prints every setting's table from the lines. The records are kept in the
repository (``benchmarks/plants/records.jsonl``; the history of what was tried is in ``benchmarks/notes/plants.md``)
and ``scripts/benchmarks_page.py`` takes BENCHMARKS.md's headline tables from them; the tables of the runs before
2026-12-01, whose records were lost with a checkout, are kept verbatim in ``tables-frozen-2026-12-01.md``.

    python scripts/bench_plants.py run --plants nominal,mass+30 --methods ksbo-adaptive --seeds 0-9 \
        --mode monitor --budget 100 --tag "what changed"
    python scripts/bench_plants.py run --plants copter3d-ardupilot,copter3d-px4 --budget 30 --seeds 0-2
    python scripts/bench_plants.py run --plants sitl-ardupilot,sitl-px4 --budget 30 --seeds 0   # slow, idle machine
    python scripts/bench_plants.py report              # every setting's table, printed
    python scripts/benchmarks_page.py                  # BENCHMARKS.md's headline from the records

Per run: the recommendation is re-flown (planar: on the plant's 8 fixed initial conditions, in the run's mode, so a
re-flight may abort or crash; copter: once, it is deterministic; SITL: 3 times, against 3 baseline re-flights)
→ E[P]; the run's own flights are counted as complete / aborted / crashed and as the paper's unsafe (P < 0). The
best E[P] known per plant is the best re-flown recommendation over every run of that plant in the file and a
reference flown by the report (planar: the nominal oracle gains; copter: the horizontal P gains at the box top).
Copter and SITL rows also give the re-flown lap-2 RMS change against the baseline (P = 1 − RMS / (2 RMS_base)).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench_plants_report import (  # noqa: E402,F401 - the report's names, also used by other scripts and tests
    FROZEN, ORACLE, RECORDS, SITL_PLANTS, best_known, frozen_best, report)


def _seeds(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b) + 1)) if b else [int(a)]
    return out


def _opt(items: list[str]) -> dict[str, Any]:
    out = {}
    for item in items:
        k, _, v = item.partition("=")
        out[k] = json.loads(v)
    return out


def _objective(plant: str, seed: int, monitor: bool) -> tuple[Any, np.ndarray, np.ndarray]:
    """(objective, x0 (d,), bounds (d, 2)) of a suite plant: planar (ksbo_sim.plants) or JSBSim copter."""
    from ksbo_mav.simulated.copter_objective import COPTER_PLANTS, CopterObjective
    from ksbo_mav.simulated.planar_objective import SimObjective

    if plant in COPTER_PLANTS:
        obj = CopterObjective(plant)  # always monitored (the profile's [safety] limits); deterministic
        return obj, obj.baseline, obj.bounds
    obj = SimObjective(seed=seed, plant=plant, monitor=monitor)
    return obj, obj.profile.default, obj.profile.bounds


def run_sitl(plant: str, method: str, seed: int, budget: int, options: dict[str, Any], n_prior: int = 0
             ) -> dict[str, Any]:
    """One campaign on a SITL: E[P] is the recommendation's mean lap-2 RMS over its 3 re-flights against the
    baseline's mean over 3 re-flights after the campaign, on the campaign's own scale P = 1 − RMS / (2 RMS_base).
    ``n_prior`` > 0: `tune --prior local --n-prior n_prior` (flown around the baseline before the optimiser)."""
    from bench_sitl_campaign import run_one as sitl_campaign

    row = sitl_campaign(SITL_PLANTS[plant], seed, budget, instance=7, method=method,
                        options=[f"{k}={json.dumps(v)}" for k, v in options.items()], n_prior=n_prior)
    rec: dict[str, Any] = {"plant": plant, "method": method, "seed": seed, "mode": "monitor", "budget": budget,
                           "n_prior": n_prior, "options": options, "sitl": row}
    if "error" in row:
        return {**rec, "EP": float("nan"), "error": row["error"], "reflown_counts": [0, 0, 0], "n_unsafe": 0,
                "n_aborted": 0, "n_crashed": 0, "s_per_iter": 0.0, "wall_s": row["wall_s"], "nfev": 0}
    change = row["best_rms"] / row["baseline_rms"] - 1.0  # over the completed re-flights (NaN if none)
    ab = int(row.get("confirm_aborted", 0))
    return {**rec, "EP": float(1.0 - row["best_rms"] / (2.0 * row["baseline_rms"])),
            "rms_change": change if np.isfinite(change) else None,
            "reflown_counts": [int(row.get("confirm_flown", 3)) - ab, ab, 0], "nfev": row["trials"],
            "n_unsafe": row["unsafe"],
            "n_aborted": row["aborted"], "n_crashed": row.get("crashed", 0), "s_per_iter": 0.0,
            "wall_s": row["wall_s"], "x": None}


def run_one(plant: str, method: str, seed: int, mode: str, budget: int, n_prior: int,
            options: dict[str, Any], local_prior: bool = False) -> dict[str, Any]:
    if plant in SITL_PLANTS:  # a SITL prior is always the campaign's local one
        return run_sitl(plant, method, seed, budget, options, n_prior)
    import ksbo_mav
    from scipy.stats import qmc

    monitor = mode == "monitor"
    obj, x0, bounds = _objective(plant, seed, monitor)
    prior = None
    n_prior_unsafe = 0
    if n_prior:
        lo, hi = bounds[:, 0], bounds[:, 1]
        if local_prior:  # what `ksbo-mav tune --prior local` flies: around the baseline
            from ksbo_mav.campaign.prior import local_prior_design

            pX = local_prior_design(n_prior, x0, bounds, seed)
        else:  # the paper setting: over the whole box
            pX = lo + qmc.LatinHypercube(d=len(lo), seed=seed).random(n_prior) * (hi - lo)
        flights = [obj(x) for x in pX]
        py = np.array([f if isinstance(f, float) else (f.value if f.value is not None else -1.0) for f in flights])
        n_prior_unsafe = int(np.sum(py < 0))
        prior = (pX, py)
    from ksbo_mav.campaign.config import profile_defaults

    t0 = time.perf_counter()
    # the profile's implied options (backup_beta where the backup covers the trials), as `ksbo-mav tune` applies
    r = ksbo_mav.optimize(obj, x0, bounds, budget=budget, method=method, seed=seed, prior=prior,
                          y_max=1.0, **{**profile_defaults(method, obj.profile), **options})
    wall = time.perf_counter() - t0
    judge = obj if hasattr(obj, "rms_ref") else type(obj)(plant=plant, monitor=monitor)  # fixed initial states
    P, counts = judge.expected_outcomes(r.x)
    props = r.info.get("proposals", [])
    rec = {
        "plant": plant, "method": method, "seed": seed, "mode": mode, "budget": budget, "n_prior": n_prior,
        "local_prior": local_prior, "options": options, "EP": float(P[0]), "reflown_counts": counts[0].tolist(),
        "x": r.x.tolist(),
        "nfev": r.nfev, "n_unsafe": r.n_unsafe, "n_aborted": r.n_aborted, "n_crashed": r.n_crashed,
        "n_prior_unsafe": n_prior_unsafe, "s_per_iter": float(np.mean(r.seconds[1:])) if r.nfev > 1 else 0.0,
        "s_per_iter_last20": float(np.mean(r.seconds[-20:])) if r.nfev > 20 else None,
        "wall_s": wall, "orders": list(r.orders or ()), "reselection_changes": r.info.get("reselection_changes"),
        "stopped": r.info.get("stopped"), "kinds": [p["kind"] for p in props],
        "first_unsafe_at": [i for i, v in enumerate(r.y) if v < 0][:10],
        "stop": ({k: r.info["stop"][k] for k in ("stopped", "after", "saved", "min_evals", "patience", "ratio")}
                 if "stop" in r.info else None),  # the stopping rule (--opt early_stop=true)
    }
    if hasattr(obj, "rms_ref"):  # copter: the re-flown recommendation's RMS change against the baseline
        rec["rms_ref"] = obj.rms_ref
        rec["rms_change"] = float((1.0 - P[0]) * obj.ratio - 1.0) if np.isfinite(P[0]) else None
        rec["best_flown_change"] = float((1.0 - np.max(r.y)) * obj.ratio - 1.0)
    return rec


def cmd_run(a: argparse.Namespace) -> None:
    from _bench_common import machine
    import scipy.linalg  # noqa: F401 - load every BLAS first: threadpool_limits only pins libraries already loaded
    from threadpoolctl import threadpool_limits

    import ksbo_mav  # noqa: F401

    threadpool_limits(1)
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    for plant in a.plants.split(","):
        for method in a.methods.split(","):
            for seed in _seeds(a.seeds):
                rec = run_one(plant, method, seed, a.mode, a.budget, a.prior, _opt(a.opt or []), a.local_prior)
                rec["tag"] = a.tag
                rec["machine"] = machine()  # CPU, cores, versions, date: the page names them
                with out.open("a") as fh:
                    fh.write(json.dumps(rec) + "\n")
                print(f"{plant:11s} {method:14s} {a.mode:7s} s{seed:<3d} E[P] {rec['EP']:+.3f} "
                      f"refl {rec['reflown_counts']} unsafe {rec['n_unsafe']} ab {rec['n_aborted']} "
                      f"cr {rec['n_crashed']} nfev {rec['nfev']} {rec['wall_s']:.0f}s"
                      + (f" RMS {rec['rms_change']:+.0%}" if rec.get("rms_change") is not None else ""), flush=True)


def compact(value: Any, digits: int = 4) -> Any:
    """``value`` with every float rounded to ``digits`` decimals (nested lists and dicts): the per-iteration
    calibration scores were 80 % of a record's size at full precision, and 4 decimals is more than their analysis
    used."""
    if isinstance(value, float):
        return round(value, digits)
    if isinstance(value, list):
        return [compact(v, digits) for v in value]
    if isinstance(value, dict):
        return {k: compact(v, digits) for k, v in value.items()}
    return value


def load_records(path: Path) -> list[dict]:
    """The run records of a JSON-lines file; a missing file or a line that is not JSON exits with a one-line error
    naming the file and line (nothing is written)."""
    if not path.is_file():
        raise SystemExit(f"bench_plants: no records file {path}")
    recs = []
    for n, line in enumerate(path.read_text().splitlines(), 1):
        if line.strip():
            try:
                recs.append(json.loads(line))
            except json.JSONDecodeError as e:
                raise SystemExit(f"bench_plants: {path}:{n} is not a JSON record ({e.msg})") from None
    return recs


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--plants", default="nominal",
                   help="comma-separated: planar suite names (ksbo_sim.plants), copter3d-ardupilot, copter3d-px4, "
                        "sitl-ardupilot, sitl-px4 (a full campaign on a fresh SITL; slow: keep the seeds few and the "
                        "machine otherwise idle)")
    r.add_argument("--methods", default="ksbo-adaptive")
    r.add_argument("--seeds", default="0-9")
    r.add_argument("--mode", choices=("monitor", "strict"), default="monitor")
    r.add_argument("--budget", type=int, default=100)
    r.add_argument("--prior", type=int, default=0, help="LHS prior flights (the paper setting: 36)")
    r.add_argument("--local-prior", action="store_true",
                   help="the prior is `tune --prior local`'s design (around the baseline), not the whole box")
    r.add_argument("--opt", action="append", help="optimizer option key=JSON value")
    r.add_argument("--tag", default="")
    r.add_argument("--out", default=str(RECORDS), help="JSON lines to append to (default: the committed records)")
    p = sub.add_parser("report")
    p.add_argument("file", nargs="?", default=str(RECORDS))
    p.add_argument("--tag", default=None, help="only runs with this tag")
    a = ap.parse_args(argv)
    if a.cmd == "run":
        cmd_run(a)
    else:
        recs = load_records(Path(a.file))
        if a.tag is not None:
            recs = [x for x in recs if x.get("tag", "") == a.tag]
        print(report(recs))


if __name__ == "__main__":
    sys.exit(main())
