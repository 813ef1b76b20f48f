"""The plant suite's own report, below the sweep pages' tables: every setting's table (options and tags apart), the
best E[P] known per plant (the records, the frozen tables of the records lost before 2026-12-01, references flown
here) and the paired per-seed comparisons (ksbo_bench.report.paired). It reads the stores of the plant sweeps as
flat records (:func:`flat`)."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np

from ksbo_bench.report.paired import paired_report, reflown_ep

DATA = Path(__file__).resolve().parents[2] / "benchmarks" / "plants"
FROZEN = DATA / "tables-frozen-2026-12-01.md"
#: End points of ``scripts/diag/safe_climb.py`` (a safe hill-climb from a0 with free flights), one JSON line per run.
CLIMBS = DATA / "safe-climb.jsonl"
ORACLE = np.array([0.2367, 0.007699, 0.8752, 3.0, 0.000393, 2.662, 1.167e4, 88.22, 9777.0])
#: SITL plants of the old records: a full `ksbo-mav tune` campaign from the ground on a fresh SITL.
SITL_PLANTS = {"sitl-ardupilot": "ardupilot", "sitl-px4": "px4"}


def flat(rec: dict[str, Any]) -> dict[str, Any]:
    """A plant-kind record as one flat dict: the key's values, the result's, the safety counts (``n_unsafe``,
    ``n_aborted``, ``n_crashed``), ``s_per_iter`` and the tag (empty for today's defaults)."""
    s, t = rec.get("safety", {}), rec.get("timing", {})
    return {"tag": "", "n_prior": 0, "mode": "monitor", **rec["key"], **rec.get("result", {}),
            "n_unsafe": s.get("unsafe", 0), "n_aborted": s.get("aborted", 0), "n_crashed": s.get("crashed", 0),
            "s_per_iter": t.get("s_per_iter") or 0.0, "nfev": rec.get("flights", {}).get("search")}


def _med(v: list[float]) -> str:
    return f"{np.median(v):.3f} [{min(v):.3f}, {max(v):.3f}]" if v else "–"


def frozen_best() -> dict[str, tuple[float, str]]:
    """Per plant: the best E[P] the frozen tables list (runs before 2026-12-01 whose records were lost)."""
    if not FROZEN.exists():
        return {}
    text = FROZEN.read_text().split("Best E[P] known per plant", 1)[-1]
    found = re.findall(r"^- (.+?): (-?[0-9.]+) \((.+)\)$", text, flags=re.M)
    return {plant: (float(v), f"{how}, frozen tables: record lost") for plant, v, how in found}


def climb_ends() -> dict[str, list[dict]]:
    """Per planar plant: the records of :data:`CLIMBS` (gains ``x`` and how they were found)."""
    out: dict[str, list[dict]] = {}
    if CLIMBS.exists():
        for line in CLIMBS.read_text().splitlines():
            if line.strip():
                rec = json.loads(line)
                out.setdefault(rec["plant"], []).append(rec)
    return out


def best_known(recs: list[dict], fly: bool = True) -> dict[str, tuple[float, str]]:
    """Per plant: best re-flown E[P] over the runs in the file, the frozen tables' best (:func:`frozen_best`) and
    references flown here — the nominal oracle gains and the end points of the safe climbs (:func:`climb_ends`)
    (planar) or the baseline with the horizontal position P gain (and the velocity P gain) at the top of the search
    box (copter; the issue's "PSC_POSXY_P 1.75 + PSC_VELXY_P 3.5" and "MPC_XY_P 1.9 alone")."""
    from ksbo_mav.simulated.copter_objective import COPTER_PLANTS, CopterObjective
    from ksbo_mav.simulated.planar_objective import SimObjective

    best: dict[str, tuple[float, str]] = {}
    frozen = frozen_best()
    climbs_all = climb_ends()
    for plant in sorted({r["plant"] for r in recs}):
        if plant in SITL_PLANTS or not fly:  # fly=False: the records and the frozen tables only (a page's report)
            best[plant] = (-np.inf, "")
        elif plant in COPTER_PLANTS:
            obj = CopterObjective(plant)
            X = np.tile(obj.baseline, (2, 1))
            X[0, 0] = obj.bounds[0, 1]
            X[1, :2] = obj.bounds[:2, 1]
            P, _ = obj.expected_outcomes(X)
            P = np.where(np.isfinite(P), P, -np.inf)
            how = ("baseline with the NE position P gain at the box top",
                   "baseline with the NE position and velocity P gains at the box top")
            best[plant] = (float(P.max()), how[int(np.argmax(P))])
        else:
            climbs = climbs_all.get(plant, [])
            X = np.array([ORACLE] + [c["x"] for c in climbs])
            P, _ = SimObjective(plant=plant).expected_outcomes(X)
            i = int(np.argmax(P))
            best[plant] = (float(P[i]), "nominal oracle gains re-flown (strict)" if i == 0 else
                           f"safe climb from a0 (scripts/diag/safe_climb.py) seed {climbs[i - 1]['seed']}, re-flown")
        for r in recs:
            if r["plant"] == plant and r["EP"] > best[plant][0]:
                best[plant] = (r["EP"], f"{r['method']} {r['mode']} seed {r['seed']} recommendation")
        old = frozen.get(plant)
        if old is not None and old[0] > best[plant][0] + 5e-4:  # the frozen values are rounded to 3 decimals
            best[plant] = old
    return best


def _rms(rs: list[dict]) -> str:
    """Copter plants: re-flown lap-2 RMS change against the baseline, median [min, max] (NaN = not complete)."""
    v = [r.get("rms_change") for r in rs]
    if all(x is None for x in v):
        return "–"
    v = [np.nan if x is None else 100 * x for x in v]
    return f"{np.nanmedian(v):+.0f} % [{np.nanmin(v):+.0f}, {np.nanmax(v):+.0f}]" + \
        (f", {sum(np.isnan(v))} not complete" if any(np.isnan(v)) else "")


#: Tag words of runs made with superseded defaults: their tables go to the end of the report, under one heading.
ARCHIVED = ("(before", "(previous")


def archived(tag: str) -> bool:
    """Whether runs with this tag were made with superseded defaults (tag ends in "(before …)"/"(previous …)")."""
    return any(w in tag for w in ARCHIVED)


def report(recs: list[dict], fly: bool = True) -> str:
    best = best_known(recs, fly)
    keys = sorted({(r["tag"] or "", r["mode"], r["method"], r["n_prior"], r["budget"]) for r in recs},
                  key=lambda k: (archived(k[0]), k))
    lines = []
    heading = False
    for tag, mode, method, n_prior, budget in keys:
        if archived(tag) and not heading:
            heading = True
            lines += ["#### Earlier generations (superseded defaults, kept for comparison)", ""]
        local = any((r.get("local_prior") or r["plant"] in SITL_PLANTS) for r in recs
                    if (r["tag"] or "", r["n_prior"], r["budget"]) == (tag, n_prior, budget))
        design = "%d LHS around the baseline (`tune --prior local`) + " if local else "%d LHS + "
        setting = f"{mode}, {design % n_prior if n_prior else 'from a0, '}{budget} flights" + \
                  (f", {tag}" if tag else "")
        lines += [f"**{method}** — {setting}", "",
                  "| plant | seeds | re-flown E[P] median [min, max] | % of best known | seeds 0 crashes "
                  "| crashes total | aborts median [max] | P<0 flights median [max] | re-flights aborted/crashed "
                  "| s/iter | copter: lap-2 RMS vs baseline |",
                  "|---|---|---|---|---|---|---|---|---|---|---|"]
        for plant in sorted({r["plant"] for r in recs}, key=lambda p: (p != "nominal", p)):
            rs = [r for r in recs if (r["tag"] or "", r["mode"], r["method"], r["n_prior"], r["budget"])
                  == (tag, mode, method, n_prior, budget) and r["plant"] == plant]
            if not rs:
                continue
            ep = [reflown_ep(r) for r in rs]
            b = best[plant][0]
            rf = np.sum([r["reflown_counts"] for r in rs], axis=0)
            ab = [r["n_aborted"] for r in rs]
            un = [r["n_unsafe"] for r in rs]
            lines.append(
                f"| {plant} | {len(rs)} | {_med(ep)} | {100 * np.median(ep) / b:.0f} % | "
                f"{sum(r['n_crashed'] == 0 for r in rs)}/{len(rs)} | {sum(r['n_crashed'] for r in rs)} | "
                f"{np.median(ab):.0f} [{max(ab)}] | {np.median(un):.0f} [{max(un)}] | {rf[1]}/{rf[2]} of "
                f"{int(rf.sum())} | {np.median([r['s_per_iter'] for r in rs]):.2f} | {_rms(rs)} |")
        lines.append("")
    lines += paired_report(recs)
    if best:
        lines += ["Best E[P] known per plant (how found; the frozen tables' values count too"
                  + ("" if fly else "; references flown by `python -m ksbo_bench.report.plants` are not") + "):", ""]
        lines += [f"- {p}: {v:.3f} ({how})" for p, (v, how) in best.items()]
    return "\n".join(lines)


if __name__ == "__main__":
    import sys

    from ksbo_bench import sweep as sweeps
    from ksbo_bench.store import Store

    names = sys.argv[1:] or ["plants-monitor", "plants-strict", "plants-paper", "plants-copter"]
    print(report([flat(r) for n in names for r in Store(sweeps.load(n).store)]))
