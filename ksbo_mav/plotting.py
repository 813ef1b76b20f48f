"""Matplotlib figures (Agg backend, written to files): trajectories against the reference."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from ksbo_mav.errors import InputError


def pyplot():
    """matplotlib.pyplot on the file-only Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_trajectories(trajectories: Sequence, labels: Sequence[str], path: str | Path,
                      title: str = "Figure-8 tracking") -> Path:
    """Reference vs flown x-z path, and x / z tracking errors over time, for one or more flights.

    Like the paper's figure comparing the initial and the tuned controller. ``trajectories`` are
    :class:`ksbo_mav.objective.Trajectory` objects; the reference is taken from the first one.
    """
    path = Path(path)
    if path.suffix.lower() not in {".png", ".pdf", ".svg"}:
        raise InputError(f"plot file must end in .png, .pdf or .svg, got {path.name!r}")
    plt = pyplot()
    fig = plt.figure(figsize=(11, 4.5), constrained_layout=True)
    grid = fig.add_gridspec(2, 2, width_ratios=[1.1, 1.4])
    ax_xz = fig.add_subplot(grid[:, 0])
    ax_ex, ax_ez = fig.add_subplot(grid[0, 1]), fig.add_subplot(grid[1, 1])
    ref = trajectories[0].refs
    ax_xz.plot(ref[:, 0], ref[:, 2], "k--", lw=1.2, label="reference")
    for traj, label in zip(trajectories, labels):
        s = traj.states
        (line,) = ax_xz.plot(s[:, 0], s[:, 2], lw=1.0, label=label)
        ax_ex.plot(traj.t, s[:, 0] - traj.refs[:, 0], lw=0.9, color=line.get_color())
        ax_ez.plot(traj.t, s[:, 2] - traj.refs[:, 2], lw=0.9, color=line.get_color())
    lap = float(np.max(trajectories[0].t)) / 2 if len(trajectories[0].t) else 0.0
    for ax, name in ((ax_ex, "x error (m)"), (ax_ez, "z error (m)")):
        ax.axhline(0.0, color="k", lw=0.6)
        ax.axvspan(lap, max(float(np.max(t.t)) for t in trajectories), color="0.92", zorder=0)
        ax.set_ylabel(name)
        ax.grid(alpha=0.3)
    ax_ez.set_xlabel("time (s)  — shaded: scored lap")
    ax_xz.set_xlabel("x (m)")
    ax_xz.set_ylabel("z (m, up)")
    ax_xz.set_aspect("equal", adjustable="datalim")
    ax_xz.legend(loc="upper right", fontsize=8)
    ax_xz.grid(alpha=0.3)
    fig.suptitle(title)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
