"""Campaign report: convergence, safety and before/after trajectory plots from a campaign directory.

Everything is read back from disk (journal, trial records, tlogs), so the report can be regenerated after the
fact and shows what was logged, not what the tuner believed in memory.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from ksbo_mav.plotting import pyplot


def _journal(d: Path) -> list[dict[str, Any]]:
    path = d / "journal.jsonl"
    out = []
    for line in path.read_text().splitlines():
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError:
            break
    return out


def _trajectory(record: str) -> Any:
    from ksbo_mav.mav.tlog import read_tlog
    from ksbo_mav.mav.trajectory import trajectory_from_tlog

    return trajectory_from_tlog(read_tlog(Path(record).with_suffix(".tlog")))[0]


def _finish(plt: Any, fig: Any, ax: Any, title: str, ylabel: str, path: Path) -> str:
    """Label a per-trial axis, save the figure to ``path`` and close it; returns the path as str."""
    ax.set_xlabel("trial")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return str(path)


def write_report(d: str | Path, profile: Any) -> dict[str, str]:
    """Write report/convergence.png, report/safety.png, report/trajectory.png; returns their paths."""
    d = Path(d)
    out = d / "report"
    out.mkdir(parents=True, exist_ok=True)
    entries = _journal(d)
    opt = [e for e in entries if e["kind"] == "opt"]
    plt = pyplot()
    paths: dict[str, str] = {}

    P = np.array([e["P"] for e in opt])
    n = np.arange(1, len(P) + 1)
    fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
    if len(P):
        ok = P >= 0
        ax.plot(n[ok], P[ok], "o", ms=4, label="trial (safe)")
        ax.plot(n[~ok], P[~ok], "x", color="C3", label="trial (unsafe / aborted)")
        ax.plot(n, np.maximum.accumulate(P), "-", color="k", lw=1.2, label="best observed")
        ax.axhline(P[0], color="0.5", ls="--", lw=1, label="baseline trial")
    ax.axhline(0.0, color="C3", lw=0.6)
    paths["convergence"] = _finish(plt, fig, ax, "Convergence", "P(a)", out / "convergence.png")

    fig, ax = plt.subplots(figsize=(7, 3.2), constrained_layout=True)
    ax.step(n, np.cumsum(P < 0) if len(P) else [], where="post", label="unsafe (P < 0)")
    ax.step(n, np.cumsum([e["outcome"] != "ok" for e in opt]) if opt else [], where="post", label="aborted")
    paths["safety"] = _finish(plt, fig, ax, "Safety", "cumulative count", out / "safety.png")

    confirm = [e for e in entries if e["kind"] == "confirm" and e["outcome"] == "ok"]
    if opt and opt[0]["outcome"] == "ok" and confirm:
        from ksbo_mav.plotting import plot_trajectories

        trajs = [_trajectory(opt[0]["record"]), _trajectory(confirm[-1]["record"])]
        labels = [f"baseline (P={opt[0]['P']:.3f})", f"tuned (P={confirm[-1]['P']:.3f})"]
        paths["trajectory"] = str(plot_trajectories(trajs, labels, out / "trajectory.png",
                                                    title="Figure-8 over MAVLink: before / after"))
    return paths
