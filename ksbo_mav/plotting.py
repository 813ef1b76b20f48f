"""Matplotlib figures (Agg backend, written to files): flown trajectories against their target, in the
mission's own frame."""

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


#: Per mission kind: the plan view (horizontal axis, vertical axis) as (state column, label), and the error panels.
#: Task states are [x, vx, z, vz, ...] for the planar figure-8 (x north, z up) and [north, v_north, east, v_east,
#: up, v_up] for the horizontal one (:func:`ksbo_mav.mav.mission.task_state`). The horizontal figure-8 is drawn as a
#: map: east to the right, north up.
FRAMES = {
    "figure8-xz": {"plan": ((0, "x = north (m)"), (2, "z = up (m)")),
                   "errors": ((0, "north error (m)"), (2, "up error (m)"))},
    "figure8-ne": {"plan": ((2, "east (m)"), (0, "north (m)")),
                   "errors": ((0, "north error (m)"), (2, "east error (m)"), (4, "altitude error (m)"))},
}


def plot_trajectories(trajectories: Sequence, labels: Sequence[str], path: str | Path,
                      title: str = "Figure-8 tracking", kind: str = "figure8-xz",
                      scored: tuple[float, float] | None = None) -> Path:
    """Reference vs flown path in the mission's plane, and the tracking errors over time, for one or more flights.

    Like the paper's figure comparing the initial and the tuned controller. ``trajectories`` are
    :class:`ksbo_task.flight.Trajectory` objects of one mission ``kind`` (``figure8-xz``: the vertical planar
    figure-8, drawn north / up; ``figure8-ne``: the copters' horizontal one, drawn as a map, east / north, with the
    altitude error); each is drawn against its own reference. ``scored``: the scored lap's time span (s), shaded;
    default the second half of the first flight.
    """
    path = Path(path)
    if path.suffix.lower() not in {".png", ".pdf", ".svg"}:
        raise InputError(f"plot file must end in .png, .pdf or .svg, got {path.name!r}")
    if kind not in FRAMES:
        raise InputError(f"unknown mission kind {kind!r} (known: {', '.join(FRAMES)})")
    (h, h_label), (v, v_label) = FRAMES[kind]["plan"]
    errors = FRAMES[kind]["errors"]
    plt = pyplot()
    fig = plt.figure(figsize=(11, 1.6 + 1.6 * len(errors)), constrained_layout=True)
    grid = fig.add_gridspec(len(errors), 2, width_ratios=[1.1, 1.4])
    ax_plan = fig.add_subplot(grid[:, 0])
    ax_err = [fig.add_subplot(grid[i, 1]) for i in range(len(errors))]
    for n, (traj, label) in enumerate(zip(trajectories, labels)):
        s, r = traj.states, traj.refs
        ax_plan.plot(r[:, h], r[:, v], "k--", lw=1.2, label="target" if n == 0 else None, zorder=3)
        (line,) = ax_plan.plot(s[:, h], s[:, v], lw=1.0, label=label)
        for ax, (col, _) in zip(ax_err, errors):
            ax.plot(traj.t, s[:, col] - r[:, col], lw=0.9, color=line.get_color())
    t_end = max((float(np.max(t.t)) for t in trajectories if len(t.t)), default=0.0)
    lo, hi = scored if scored is not None else (t_end / 2, t_end)
    for ax, (_, name) in zip(ax_err, errors):
        ax.axhline(0.0, color="k", lw=0.6)
        ax.axvspan(lo, hi, color="0.92", zorder=0)
        ax.set_ylabel(name)
        ax.grid(alpha=0.3)
    ax_err[-1].set_xlabel("time (s)  — shaded: scored lap")
    ax_plan.set_xlabel(h_label)
    ax_plan.set_ylabel(v_label)
    ax_plan.set_aspect("equal", adjustable="datalim")
    ax_plan.legend(loc="upper right", fontsize=8)
    ax_plan.grid(alpha=0.3)
    fig.suptitle(title)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def scored_span(info: dict) -> tuple[float, float]:
    """The scored lap's time span (s) from a replayed trial's info (:meth:`TrialRecorder.trajectory`)."""
    lo, hi = info["window"]
    return lo * info["dt_ms"] / 1000.0, hi * info["dt_ms"] / 1000.0
