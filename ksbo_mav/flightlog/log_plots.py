"""Figures of a scored log segment (top view, setpoint against estimate with the modes shaded, error over time,
error spectrum) and of two logs compared."""

from __future__ import annotations

from dataclasses import replace

from pathlib import Path
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.flightlog.analysis import reference
from ksbo_mav.flightlog.model import FlightLog


def check_plot_path(path: str | Path) -> Path:
    """The plot's path, its directory created; InputError (one line) when it cannot be written there."""
    path = Path(path)
    if path.suffix.lower() not in {".png", ".pdf", ".svg"}:
        raise InputError(f"plot file must end in .png, .pdf or .svg, got {path.name!r}")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot write plot {path}: {exc.strerror or exc}") from None
    return path


def _save(fig, path: Path) -> None:
    import matplotlib.pyplot as plt

    try:
        fig.savefig(path, dpi=110)
    except OSError as exc:
        raise InputError(f"cannot write plot {path}: {exc.strerror or exc}") from None
    finally:
        plt.close(fig)


def _series(log: FlightLog, seg: dict[str, Any], mission) -> dict[str, Any]:
    """Times (s from the segment's or figure-8's start), actual, target, reference and errors of one segment."""
    f8 = seg.get("figure8")
    a, b = (f8["t0_s"], f8["t_end_s"]) if f8 else (seg["t_start_s"], seg["t_end_s"])
    act = log.actual.window(a, b)
    tgt = log.target.window(a, b)
    out = {"t0": a, "act": act, "tgt": tgt, "t_act": act.t - a, "t_tgt": tgt.t - a, "f8": f8}
    e = log.actual.at(tgt.t) - tgt.pos
    out["e_tgt_h"], out["e_tgt_v"] = np.hypot(e[:, 0], e[:, 1]), e[:, 2]
    if f8:
        fitted = replace(mission, lead_in=f8["mission"].get("lead_in_s", 0.0))  # the variant recognised
        ref, _ = reference(fitted, act.t - a, np.array(f8["offset_m"]))
        out["ref"] = ref
        er = act.pos - ref
        out["e_ref_h"], out["e_ref_v"] = np.hypot(er[:, 0], er[:, 1]), er[:, 2]
    return out


MODE_COLOURS = ("#e8f1fb", "#fdf0e2", "#eaf6ea", "#f6e9f4", "#f3f3f3")


def _shade_modes(ax, log: FlightLog, t0: float, a: float, b: float) -> None:
    """Shade each flight mode over [a, b] (times relative to ``t0``) and name it at the top of the axes."""
    names: dict[str, str] = {}
    for m, nxt in zip(log.modes, list(log.modes[1:]) + [None]):
        lo, hi = max(m.t, a), min(nxt.t if nxt else b, b)
        if hi <= lo:
            continue
        col = names.setdefault(m.name, MODE_COLOURS[len(names) % len(MODE_COLOURS)])
        ax.axvspan(lo - t0, hi - t0, color=col, lw=0, zorder=0)
        ax.text((lo + hi) / 2 - t0, 0.97, m.name, transform=ax.get_xaxis_transform(), ha="center", va="top",
                fontsize=6, color="0.35", clip_on=True)


def plot_segment(log: FlightLog, seg: dict[str, Any], mission, path: str | Path, title: str = "") -> Path:
    """One scored segment on one page: top view (target, flown, figure-8 reference), north/east/down position and
    horizontal speed, setpoint against estimate, with the flight modes shaded (5 s either side of the segment),
    the error against the target over time, and that error's amplitude spectrum (an oscillating loop is a peak)."""
    from ksbo_mav.flightlog.spectrum import error_spectrum
    from ksbo_mav.plotting import pyplot

    path = check_plot_path(path)
    s = _series(log, seg, mission)
    plt = pyplot()
    fig = plt.figure(figsize=(13, 9), constrained_layout=True)
    grid = fig.add_gridspec(4, 2, width_ratios=[1.0, 1.6])
    ax_ne, ax_sp = fig.add_subplot(grid[:2, 0]), fig.add_subplot(grid[2:, 0])
    ax_p = fig.add_subplot(grid[0, 1])
    ax_v, ax_h, ax_d = (fig.add_subplot(grid[k, 1], sharex=ax_p) for k in (1, 2, 3))
    if "ref" in s:
        ax_ne.plot(s["ref"][:, 1], s["ref"][:, 0], "k--", lw=1.0, label="figure-8 reference")
    ax_ne.plot(s["tgt"].pos[:, 1], s["tgt"].pos[:, 0], color="tab:orange", lw=1.0, label=f"target: {log.target.label}")
    ax_ne.plot(s["act"].pos[:, 1], s["act"].pos[:, 0], color="tab:blue", lw=1.0, label=f"flown: {log.actual.label}")
    ax_ne.set(xlabel="east (m)", ylabel="north (m)")
    ax_ne.set_aspect("equal", adjustable="datalim")
    ax_ne.legend(loc="upper right", fontsize=7)
    t0, a, b = s["t0"], s["t0"] - 5.0, s["t0"] + (s["t_act"][-1] if len(s["t_act"]) else 0.0) + 5.0
    act, tgt = log.actual.window(a, b), log.target.window(a, b)
    for k, (name, ls) in enumerate((("north", "-"), ("east", "--"), ("down", ":"))):
        ax_p.plot(tgt.t - t0, tgt.pos[:, k], color="tab:orange", lw=0.9, ls=ls)
        ax_p.plot(act.t - t0, act.pos[:, k], color="tab:blue", lw=0.9, ls=ls, label=name)
    ax_p.set_ylabel("position (m)")
    ax_p.legend(loc="upper right", fontsize=7, ncol=3, title="orange target, blue flown", title_fontsize=7)
    for tr, col, lab in ((tgt, "tab:orange", "target"), (act, "tab:blue", "flown")):
        if tr.vel is not None and len(tr):
            ax_v.plot(tr.t - t0, np.hypot(tr.vel[:, 0], tr.vel[:, 1]), color=col, lw=0.9, label=lab)
        elif len(tr) > 2:  # no velocity in the log: differentiate the positions
            v = np.gradient(tr.pos[:, :2], tr.t, axis=0)
            ax_v.plot(tr.t - t0, np.hypot(v[:, 0], v[:, 1]), color=col, lw=0.9, label=lab + " (from positions)")
    ax_v.set_ylabel("horizontal speed (m/s)")
    ax_h.plot(s["t_tgt"], s["e_tgt_h"], color="tab:orange", lw=0.9, label="vs autopilot target")
    ax_d.plot(s["t_tgt"], s["e_tgt_v"], color="tab:orange", lw=0.9, label="vs autopilot target")
    if "ref" in s:
        ax_h.plot(s["t_act"], s["e_ref_h"], color="k", lw=0.9, ls="--", label="vs analytic reference")
        ax_d.plot(s["t_act"], s["e_ref_v"], color="k", lw=0.9, ls="--", label="vs analytic reference")
        T = s["f8"]["mission"]["period_s"]
        for k in range(1, int(s["f8"]["laps_flown"]) + 1):
            for ax in (ax_h, ax_d):
                ax.axvline(k * T, color="0.6", lw=0.8)
    ax_h.set_ylabel("horizontal error (m)")
    ax_d.set_ylabel("vertical error, down (m)")
    ax_d.set_xlabel("time (s) from the " + ("figure-8 start (lines: laps)" if s["f8"] else "segment start"))
    for ax in (ax_p, ax_v, ax_h, ax_d):
        _shade_modes(ax, log, t0, a, b)
        ax.grid(alpha=0.3)
    for ax in (ax_v, ax_h, ax_d):
        ax.legend(loc="upper right", fontsize=7)
    spec = error_spectrum(log, seg["t_start_s"], seg["t_end_s"])
    if spec is not None:
        ax_sp.plot(spec["freq_hz"], spec["amp_h_m"], color="tab:blue", lw=0.9, label="horizontal")
        ax_sp.plot(spec["freq_hz"], spec["amp_v_m"], color="tab:green", lw=0.9, label="vertical")
        ax_sp.axvline(spec["peak_hz"], color="tab:red", lw=0.8, ls="--",
                      label=f"peak {spec['peak_hz']:.2f} Hz, {spec['peak_amp_m']:.3f} m")
        ax_sp.set_xscale("log")
        ax_sp.legend(loc="upper right", fontsize=7)
    else:
        ax_sp.text(0.5, 0.5, "too few target samples for a spectrum", ha="center", transform=ax_sp.transAxes)
    ax_sp.set(xlabel="frequency (Hz)", ylabel="error amplitude (m)", title="tracking error spectrum")
    ax_sp.grid(alpha=0.3)
    fig.suptitle(title or f"{Path(log.path).name}: segment {seg['segment']} ({seg['mode']})")
    _save(fig, path)
    plt.close(fig)
    return path


def plot_compare(runs: list[tuple[str, FlightLog, dict[str, Any]]], mission, path: str | Path) -> Path:
    """Two (or more) logs' segments: top view and horizontal error over time, one colour per log."""
    from ksbo_mav.plotting import pyplot

    path = check_plot_path(path)
    plt = pyplot()
    fig = plt.figure(figsize=(12, 5), constrained_layout=True)
    grid = fig.add_gridspec(2, 2, width_ratios=[1.0, 1.5])
    ax_ne = fig.add_subplot(grid[:, 0])
    ax_h, ax_v = fig.add_subplot(grid[0, 1]), fig.add_subplot(grid[1, 1])
    drew_ref = False
    for label, log, seg in runs:
        s = _series(log, seg, mission)
        if "ref" in s and not drew_ref:
            ax_ne.plot(s["ref"][:, 1], s["ref"][:, 0], "k--", lw=1.0, label="figure-8 reference")
            drew_ref = True
        (line,) = ax_ne.plot(s["act"].pos[:, 1], s["act"].pos[:, 0], lw=1.0, label=label)
        key = "e_ref" if "ref" in s else "e_tgt"
        tt = s["t_act"] if "ref" in s else s["t_tgt"]
        ax_h.plot(tt, s[key + "_h"], lw=0.9, color=line.get_color())
        ax_v.plot(tt, s[key + "_v"], lw=0.9, color=line.get_color())
    ax_ne.set_xlabel("east (m)")
    ax_ne.set_ylabel("north (m)")
    ax_ne.set_aspect("equal", adjustable="datalim")
    ax_ne.legend(loc="upper right", fontsize=7)
    ax_ne.grid(alpha=0.3)
    ax_h.set_ylabel("horizontal error (m)")
    ax_v.set_ylabel("vertical error (m)")
    ax_v.set_xlabel("time (s) from the figure-8 (or segment) start")
    for ax in (ax_h, ax_v):
        ax.grid(alpha=0.3)
    fig.suptitle("compare: " + "  vs  ".join(label for label, _, _ in runs))
    _save(fig, path)
    plt.close(fig)
    return path
