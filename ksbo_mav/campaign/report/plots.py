"""The report's per-trial plots: convergence (every flown trial), each gain against its bounds, safety counts.

The x axis is always the trial number the console printed. Markers say what a trial was (baseline, prior,
optimiser, re-flight, confirmation) and how it ended (unsafe P < 0, aborted, crashed); interrupted trials (not the
gains' doing) are grey vertical lines.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ksbo_mav.campaign.box_edge import EdgeHit
from ksbo_mav.campaign.report.rows import SAFETY, CampaignRecord, TrialRow
from ksbo_mav.plotting import pyplot

#: Marker style of each class of trial: (legend label, matplotlib keyword arguments).
STYLES: dict[str, tuple[str, dict[str, Any]]] = {
    "baseline": ("baseline", dict(marker="s", color="k", ms=7)),
    "baseline re-flight": ("baseline re-flight", dict(marker="s", color="k", mfc="none", ms=7)),
    "prior": ("flown prior", dict(marker="^", color="C7", ms=6)),
    "optimiser": ("optimiser", dict(marker="o", color="C0", ms=5)),
    "re-flight": ("re-flight of an earlier trial", dict(marker="o", color="C0", mfc="none", ms=7)),
    "confirmation": ("confirmation of the recommendation", dict(marker="D", color="C2", ms=6)),
    "unsafe": ("unsafe (P < 0)", dict(marker="v", color="C3", ms=7)),
    "aborted": ("aborted by the monitor", dict(marker="x", color="C3", ms=8, mew=2)),
    "crashed": ("crashed", dict(marker="X", color="darkred", ms=10)),
}


def style_key(row: TrialRow) -> str:
    """Which :data:`STYLES` entry a (not interrupted) trial is drawn with: how it ended first, then its role."""
    o = row.entry.outcome
    if o == "crash":
        return "crashed"
    if o.gain_caused:
        return "aborted"
    if o != "ok" or row.P < 0:
        return "unsafe"
    return "re-flight" if row.role.startswith("re-flight") else row.role if row.role in STYLES else "optimiser"


def _by_style(rows: Sequence[TrialRow]) -> dict[str, list[TrialRow]]:
    groups: dict[str, list[TrialRow]] = {k: [] for k in STYLES}
    for r in rows:
        if r.kind != "failed":
            groups[style_key(r)].append(r)
    return {k: v for k, v in groups.items() if v}


def _interrupted(ax: Any, rows: Sequence[TrialRow], label: bool = True) -> None:
    for n, r in enumerate(r for r in rows if r.kind == "failed"):
        ax.axvline(r.trial, color="0.6", ls=":", lw=1.2,
                   label="interrupted (not the gains)" if label and n == 0 else None)


def _trial_axis(ax: Any, rows: Sequence[TrialRow]) -> None:
    """Integer trial numbers, every flown trial in view (an interrupted one at the edge too)."""
    from matplotlib.ticker import MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(integer=True, min_n_ticks=1))
    if rows:
        ax.set_xlim(rows[0].trial - 0.5, rows[-1].trial + 0.5)


def _finish(plt: Any, fig: Any, ax: Any, rows: Sequence[TrialRow], title: str, ylabel: str, path: Path) -> str:
    """Label a per-trial axis, save the figure to ``path`` and close it."""
    _trial_axis(ax, rows)
    ax.set_xlabel("trial (as numbered on the console)")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.01, 0.5))
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return str(path)


def plot_convergence(rec: CampaignRecord, path: Path) -> str:
    """P of every flown trial by trial number, the optimiser's best so far, the baseline and P = 0."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 4), constrained_layout=True)
    for key, rows in _by_style(rec.rows).items():
        label, kw = STYLES[key]
        ax.plot([r.trial for r in rows], [r.P for r in rows], ls="none", label=label, **kw)
    opt = [r for r in rec.rows if r.kind == "opt"]
    if opt:
        best = np.maximum.accumulate([r.P if r.entry.outcome == "ok" else -np.inf for r in opt])
        t = [r.trial for r in opt]
        ax.step(t + [rec.rows[-1].trial], list(best) + [best[-1]], where="post", color="k", lw=1.0,
                label="optimiser's best so far")
        ax.axhline(opt[0].P, color="0.5", ls="--", lw=1, label=f"baseline P (trial {opt[0].trial})")
    _interrupted(ax, rec.rows)
    ax.axhline(0.0, color="C3", lw=0.8, label="P = 0 (safety threshold)")
    return _finish(plt, fig, ax, rec.rows, "Convergence: every flown trial", "P", path)


def plot_safety(rec: CampaignRecord, path: Path) -> str | None:
    """Cumulative unsafe / aborted / crashed / interrupted counts; None (no file) when all four stay zero."""
    rows = rec.rows
    counts = {label: [label in r.safety for r in rows] for label in SAFETY}
    if not any(any(v) for v in counts.values()):
        return None
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 3.2), constrained_layout=True)
    # From zero before the first trial to the count after the last, so that a single trial draws a step too.
    t = [rows[0].trial - 0.5] + [r.trial for r in rows] + [rows[-1].trial + 0.5]
    for n, (label, flags) in enumerate(counts.items()):
        if any(flags):  # a class that stays at zero is named in the title instead of hiding under the others
            y = np.cumsum([0, *flags])
            ax.step(t, [*y, y[-1]], where="post", label=f"{label}: {y[-1]}", color=f"C{n}", lw=1.5)
    zero = [label for label, flags in counts.items() if not any(flags)]
    title = "Safety" + (f"; zero: {', '.join(zero)}" if zero else "")
    from matplotlib.ticker import MaxNLocator

    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    return _finish(plt, fig, ax, rows, title, "cumulative count", path)


def plot_gains(rec: CampaignRecord, best: np.ndarray | None, limits: np.ndarray | None, hits: Sequence[EdgeHit],
               path: Path) -> str:
    """One panel per gain: its value in every flown trial, the search box (shaded), the profile's limits
    (dashed), the baseline (dotted) and the recommendation (green); a gain on a box edge has a red title."""
    plt = pyplot()
    d = len(rec.names)
    cols = 3 if d > 4 else 2 if d > 1 else 1
    nrows = math.ceil(d / cols)
    fig, axes = plt.subplots(nrows, cols, figsize=(4.1 * cols, 2.5 * nrows + 0.6), constrained_layout=True,
                             squeeze=False)
    groups = _by_style(rec.rows)
    base = rec.to_params(rec.x0)
    on_edge = {h.name: h for h in hits}
    for i, name in enumerate(rec.names):
        ax = axes.flat[i]
        lo, hi = rec.bounds[i]
        ax.axhspan(lo, hi, color="C0", alpha=0.08, label="search box")
        if limits is not None:
            for v in limits[i]:
                ax.axhline(v, color="0.4", ls="--", lw=0.9, label="profile limit" if v == limits[i][0] else None)
        ax.axhline(base[i], color="k", ls=":", lw=1.0, label="baseline value")
        for key, rows in groups.items():
            label, kw = STYLES[key]
            ax.plot([r.trial for r in rows], [r.values[name] for r in rows], ls="none", label=label,
                    **{**kw, "ms": kw.get("ms", 5) * 0.7})
        if best is not None:
            ax.axhline(best[i], color="C2", lw=1.4, label="recommendation")
        _interrupted(ax, rec.rows, label=False)
        hit = on_edge.get(name)
        ax.set_title(name + (f"  (at the {hit.side} bound)" if hit else ""), fontsize=9,
                     color="C3" if hit else "k")
        _trial_axis(ax, rec.rows)
        ax.tick_params(labelsize=8)
        ax.grid(alpha=0.3)
    for ax in axes.flat[d:]:
        ax.axis("off")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=min(5, len(labels)), fontsize=8)
    fig.suptitle("Gains through the campaign (x: trial number as on the console)")
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return str(path)
