"""Campaign report: convergence, safety and before/after trajectory plots from a campaign directory.

Everything is read back from disk (journal, trial records, tlogs), so the report can be regenerated after the
fact and shows what was logged, not what the tuner believed in memory. Trial numbers are the ones the console
printed (0-based, every flown trial counted).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ksbo_mav.campaign.journal import Journal
from ksbo_mav.campaign.layout import CampaignDir
from ksbo_mav.plotting import pyplot


def _trajectory(record: str) -> Any:
    from ksbo_mav.mav.tlog import read_tlog
    from ksbo_mav.mav.trajectory import trajectory_from_tlog

    return trajectory_from_tlog(read_tlog(Path(record).with_suffix(".tlog")))[0]


def _finish(plt: Any, fig: Any, ax: Any, title: str, ylabel: str, path: Path) -> str:
    """Label a per-trial axis (integer trial numbers), save the figure to ``path`` and close it."""
    from matplotlib.ticker import MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("trial (as numbered on the console)")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return str(path)


def write_report(d: CampaignDir | str | Path, profile: Any) -> dict[str, str]:
    """Write report/convergence.png, report/safety.png (only when a trial was unsafe or aborted) and
    report/trajectory.png; returns {name: path}, plus {"safety": "none"} when there was nothing to plot."""
    d = d if isinstance(d, CampaignDir) else CampaignDir.at(d)
    d.report.mkdir(parents=True, exist_ok=True)
    journal = Journal(d.journal)
    opt = journal.of("opt")
    confirm = journal.of("confirm")
    plt = pyplot()
    paths: dict[str, str] = {}

    n = np.array([e.trial for e in opt])
    P = np.array([e.P for e in opt])
    fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
    if len(P):
        ok = np.array([e.outcome == "ok" and e.P >= 0 for e in opt])
        ax.plot(n[ok], P[ok], "o", ms=4, label="optimiser trial")
        if (~ok).any():
            ax.plot(n[~ok], P[~ok], "x", color="C3", label="unsafe (P < 0) / aborted")
        ax.plot(n, np.maximum.accumulate(P), "-", color="k", lw=1.2, label="best so far")
        ax.axhline(P[0], color="0.5", ls="--", lw=1, label=f"baseline (trial {n[0]})")
    if confirm:
        ax.plot([e.trial for e in confirm], [e.P for e in confirm], "D", color="C2", ms=6,
                label="confirmation of the recommendation")
    ax.axhline(0.0, color="C3", lw=0.8, label="P = 0 (safety threshold)")
    paths["convergence"] = _finish(plt, fig, ax, "Convergence", "P", d.report / "convergence.png")

    flown = journal.entries
    bad = [e for e in flown if e.P < 0 or e.outcome != "ok"]
    if bad:
        fig, ax = plt.subplots(figsize=(7, 3.2), constrained_layout=True)
        t = np.array([e.trial for e in flown])
        ax.step(t, np.cumsum([e.kind == "opt" and e.P < 0 for e in flown]), where="post", label="unsafe (P < 0)")
        ax.step(t, np.cumsum([e.outcome.gain_caused and e.outcome != "crash" for e in flown]), where="post",
                label="aborted by the monitor (recovered)")
        ax.step(t, np.cumsum([e.outcome == "crash" for e in flown]), where="post", label="crashed")
        ax.step(t, np.cumsum([e.kind == "failed" for e in flown]), where="post", label="failed (not the gains)")
        paths["safety"] = _finish(plt, fig, ax, "Safety", "cumulative count", d.report / "safety.png")
    else:
        paths["safety"] = "none"  # no unsafe, aborted or failed trial: nothing to plot

    ok_confirm = [e for e in confirm if e.outcome == "ok"]
    if opt and opt[0].outcome == "ok" and ok_confirm:
        from ksbo_mav.plotting import plot_trajectories

        trajs = [_trajectory(opt[0].record), _trajectory(ok_confirm[-1].record)]
        labels = [f"baseline, trial {opt[0].trial} (P={opt[0].P:.3f})",
                  f"tuned, trial {ok_confirm[-1].trial} (P={ok_confirm[-1].P:.3f})"]
        paths["trajectory"] = str(plot_trajectories(trajs, labels, d.report / "trajectory.png",
                                                    title="Figure-8 over MAVLink: before / after"))
    return paths
