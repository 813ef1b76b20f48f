"""The kernel-selection sweep's part of its page: one table per measure (ksbo_bench.evaluations.kernel_selection)."""

from __future__ import annotations

from typing import Any

ORDERS = range(1, 10)


def _by(recs: list[dict[str, Any]], measure: str) -> list[dict[str, Any]]:
    return [r for r in recs if r["key"].get("measure") == measure]


def _cols(k: dict[str, Any]) -> str:
    return "exact (c = l)" if int(k.get("columns", 29)) == 36 else f"Nyström c = k = {k.get('columns', 29)}"


def report(recs: list[dict[str, Any]]) -> str:
    from ksbo_mav.profiles import load_profile

    out: list[str] = []
    syn = _by(recs, "synthetic")
    if syn:
        out += ["**Synthetic functions of known order** (36 LHS points, 9-D)", "",
                "| function (true order) | criterion | top-3 per LHS seed | seeds whose top-1 is the true order |",
                "|---|---|---|---|"]
        out += [f"| {r['key']['function']} | {_cols(r['key'])} | {' '.join(r['result']['tops'])} | "
                f"{r['result']['hits']}/{len(r['result']['tops'])} |" for r in syn] + [""]
    for r in _by(recs, "prior-cree"):
        x = r["result"]
        out += [f"**{r['key']['design']} design, prior seed 0** ({x['unsafe']}/36 unsafe, P median "
                f"{x['P_median']:.3f}): chosen {', '.join(map(str, x['orders']))}", "",
                "| order | " + " | ".join(map(str, ORDERS)) + " |", "|---" * 10 + "|"]
        for k, label in (("mean", "mean C_ree"), ("std", "std"), ("exact", "exact (c = l)")):
            out.append(f"| {label} | " + " | ".join(f"{x[k][str(o)]:.4f}" for o in ORDERS) + " |")
        out += ["| top-3 freq | " + " | ".join(f"{100 * x['top_frequency'][str(o)]:.0f} %" for o in ORDERS) + " |", ""]
    st = _by(recs, "stability")
    if st:
        out += ["**Stability over prior seeds** (top 3 per seed; counts: seeds with the order in the top 3)", "",
                "| design | setting | top-3 per seed | order counts 1..9 | {2, 3, 4} (the paper's) |",
                "|---|---|---|---|---|"]
        out += [f"| {r['key']['design']} | {_cols(r['key'])} | {' '.join(r['result']['tops'])} | "
                f"{' '.join(map(str, r['result']['counts']))} | {r['result']['paper']}/{len(r['result']['tops'])} |"
                for r in st] + [""]
    se = _by(recs, "sensitivity")
    if se:
        out += ["**Sensitivity to mu and the lengthscale** (order counts in the top 3 over prior seeds)", "",
                "| design | mu | lengthscale | order counts 1..9 | most frequent top-3 |", "|---|---|---|---|---|"]
        for r in se:
            tops = r["result"]["tops"]
            mode = max(sorted(set(tops)), key=tops.count)  # ties: the first in order, the same on every run
            out.append(f"| {r['key']['design']} | {r['key']['mu']:g} | {r['key']['lengthscale']:g} | "
                       f"{' '.join(map(str, r['result']['counts']))} | {mode} ({tops.count(mode)}/{len(tops)}) |")
        out.append("")
    dims = _by(recs, "dimensions")
    if dims:
        names = load_profile("sim-planar").names
        out += ["**Dimension selection** (order 2; how often each gain is kept over prior seeds)", "",
                "| design | method | " + " | ".join(names) + " | mean kept |", "|---" * (len(names) + 3) + "|"]
        out += [f"| {r['key']['design']} | {r['key']['method']} | {' | '.join(map(str, r['result']['counts']))} | "
                f"{r['result']['mean_kept']:.1f} |" for r in dims] + [""]
    for r in _by(recs, "heldout"):
        rm = r["result"]["rmse"]
        out += [f"**Held-out check, {r['key']['design']} design** ({len(r['result']['chosen'])} priors; test RMSE / "
                "std(prior P), lower is better, 1.0 = predicting the mean; C_ree's top 3 on these priors: "
                f"{' '.join(r['result']['chosen'])})", "", "| kernel orders | " + " | ".join(rm) + " |",
                "|---" * (len(rm) + 1) + "|",
                "| test RMSE / std | " + " | ".join(f"{v:.3f}" for v in rm.values()) + " |",
                ""]
    return "\n".join(out).strip()
