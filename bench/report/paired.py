"""Paired comparison of methods flown on the same plants and seeds (the paper-setting goal: "ksbo at least
level with `standard` and `safeopt` on every plant and ahead on most").

Medians of 20 runs move by a few hundredths from seed to seed, so a median comparison calls a plant "behind" on
noise. Runs of two methods with the same plant, seed and setting share their LHS prior and initial conditions, so
their per-seed difference is the fairer measure: its mean ± standard error, wins/losses, and the two-sided Wilcoxon
signed-rank p-value. A plant is *ahead* / *behind* when p < 0.05 (each plant and baseline tested alone: with 20
tests, one false call at that level is expected by chance), otherwise *level*. The test ranks the differences, so
a plant can be *ahead* with a mean difference near zero when most seeds gain a little and one loses a lot: the
table gives the median difference too.

The records here are flat (ksbo_bench.report.plants.flat: the key's values, the result's, the safety counts as
``n_unsafe``, ``n_crashed``).
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np
from scipy.stats import wilcoxon

ALPHA = 0.05


def reflown_ep(r: dict) -> float:
    """A record's re-flown E[P]; -1 when the re-flight aborted (NaN), as in the report's tables."""
    return r["EP"] if np.isfinite(r["EP"]) else -1.0


def paired_rows(recs: list[dict], ref: str, other: str) -> list[tuple]:
    """Per plant: (plant, n, mean difference ref − other, its standard error, wins, losses, p, verdict, P < 0
    flights ref/other, crashes ref/other, median difference) over the seeds both methods flew. ``recs`` must be one
    setting (mode, prior, budget, tag)."""
    by: dict[tuple[str, str], dict[int, float]] = defaultdict(dict)
    bad: dict[tuple[str, str], dict[int, tuple[int, int]]] = defaultdict(dict)
    for r in recs:
        by[(r["method"], r["plant"])][r["seed"]] = reflown_ep(r)
        bad[(r["method"], r["plant"])][r["seed"]] = (r["n_unsafe"], r["n_crashed"])
    rows = []
    for plant in sorted({r["plant"] for r in recs}, key=lambda p: (p != "nominal", p)):
        a, b = by.get((ref, plant), {}), by.get((other, plant), {})
        seeds = sorted(set(a) & set(b))
        if len(seeds) < 5:
            continue
        d = np.array([a[s] - b[s] for s in seeds])
        p = float(wilcoxon(d, zero_method="zsplit").pvalue) if np.any(d != 0) else 1.0
        verdict = "level" if p >= ALPHA else ("ahead" if np.median(d) > 0 else "behind")
        ua, ca = np.sum([bad[(ref, plant)][s] for s in seeds], axis=0)
        ub, cb = np.sum([bad[(other, plant)][s] for s in seeds], axis=0)
        rows.append((plant, len(seeds), float(d.mean()), float(d.std(ddof=1) / np.sqrt(len(d))),
                     int(np.sum(d > 0)), int(np.sum(d < 0)), p, verdict, f"{ua}/{ub}", f"{ca}/{cb}",
                     float(np.median(d))))
    return rows


def paired_report(recs: list[dict], ref: str = "ksbo") -> list[str]:
    """Markdown: for each untagged setting where ``ref`` and other methods flew the same seeds, one table of the
    paired differences (empty when there is none)."""
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for r in recs:
        if not r.get("tag"):
            groups[(r["mode"], r["n_prior"], r["budget"])].append(r)
    lines: list[str] = []
    for (mode, n_prior, budget), rs in sorted(groups.items(), key=lambda kv: str(kv[0])):
        others = sorted({r["method"] for r in rs} - {ref})
        tables = {m: paired_rows(rs, ref, m) for m in others}
        tables = {m: t for m, t in tables.items() if t}
        if not tables:  # no other method shares 5 seeds with ref (or ref did not fly this setting)
            continue
        setting = f"{mode}, {f'{n_prior} LHS + ' if n_prior else 'from a0, '}{budget} flights"
        lines += [f"**Paired: `{ref}` against each method on the same seeds** — {setting}. Difference of re-flown "
                  f"E[P] per seed, mean ± standard error; wins/losses; Wilcoxon signed-rank p (two-sided); verdict at "
                  f"p < {ALPHA} (ksbo_bench.report.paired).", "",
                  "| plant | " + " | ".join(f"vs `{m}`: n, mean ± se (median), wins/losses, p, verdict; P<0 flights, "
                                          f"crashes ({ref}/{m})" for m in tables) + " |",
                  "|---|" + "---|" * len(tables)]
        plants = [row[0] for row in next(iter(tables.values()))]
        for plant in plants:
            cells = []
            for t in tables.values():
                row = next((x for x in t if x[0] == plant), None)
                cells.append("–" if row is None else
                             f"{row[1]}, {row[2]:+.3f} ± {row[3]:.3f} ({row[10]:+.3f}), {row[4]}/{row[5]}, "
                             f"{row[6]:.2f}, **{row[7]}**; {row[8]}, {row[9]}")
            lines.append(f"| {plant} | " + " | ".join(cells) + " |")
        for m, t in tables.items():
            count = {v: sum(row[7] == v for row in t) for v in ("ahead", "level", "behind")}
            d = [row[2] for row in t]
            lines.append(f"\nAgainst `{m}`: ahead on {count['ahead']}, level on {count['level']}, behind on "
                         f"{count['behind']} of {len(t)} plants; mean difference over the plants {np.mean(d):+.3f}.")
        lines.append("")
    return lines
