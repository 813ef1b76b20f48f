"""The report's view of a vehicle that changes: the baseline flights (first and re-flights) and the conditions
each trial flew in (wind, battery voltage), over the campaign, and every trial judged against the baseline flown
in its own condition. (The drift test's verdict itself is :func:`ksbo_mav.campaign.drift.load_drift`.)"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ksbo_mav.campaign.report.rows import CampaignRecord
from ksbo_mav.plotting import pyplot


def plot_conditions(rec: CampaignRecord, path: Path) -> str | None:
    """Baseline flights (lap RMS, else P) and each trial's wind and battery voltage, by trial; None when the
    campaign re-flew no baseline and recorded no conditions."""
    base = [r for r in rec.rows if r.role in ("baseline", "baseline re-flight") and r.entry.outcome == "ok"]
    cond = [r for r in rec.rows if r.entry.cond]
    wind = [(r.trial, r.entry.cond["wind_mps"]) for r in cond if r.entry.cond.get("wind_mps") is not None]
    # A vehicle that does not estimate the wind streams a zero: said, never drawn as a measurement; what the
    # flights' own telemetry tells is drawn apart, labelled as inferred.
    unestimated = any(r.entry.cond.get("wind_estimated") is False for r in cond)
    inferred = [(r.trial, r.entry.cond["wind_inferred_mps"]) for r in cond
                if r.entry.cond.get("wind_inferred_mps") is not None]
    volt = [(r.trial, r.entry.cond["voltage_v"]) for r in cond if r.entry.cond.get("voltage_v") is not None]
    if len(base) < 2 and not wind and not volt and not unestimated:
        return None
    plt = pyplot()
    fig, axes = plt.subplots(3, 1, figsize=(9, 6.5), sharex=True, constrained_layout=True)
    rms = all(r.rms is not None for r in base)
    axes[0].plot([r.trial for r in base], [r.rms if rms else r.P for r in base], "o-", color="C0",
                 label="baseline gains, each flight")
    axes[0].set_ylabel("lap-2 RMS (m)" if rms else "P")
    axes[0].set_title("The baseline gains re-flown, and the conditions, over the campaign")
    for ax, pts, label, unit in ((axes[1], wind, "wind (autopilot estimate)", "m/s"),
                                 (axes[2], volt, "battery voltage", "V")):
        if ax is axes[1] and inferred:
            ax.plot([t for t, _ in inferred], [v for _, v in inferred], "x", color="C2",
                    label="wind inferred (lean angle against ground velocity)")
        if pts:
            ax.plot([t for t, _ in pts], [v for _, v in pts], ".", color="C1", label=label)
        elif ax is axes[1] and unestimated:
            ax.text(0.5, 0.3 if inferred else 0.5, "wind: not estimated by the vehicle (no drag fusion or "
                    "airspeed sensor)", transform=ax.transAxes, ha="center", color="0.4")
        if ax is axes[1] and (pts or inferred):
            ax.set_ylim(bottom=0.0, top=1.15 * max(v for _, v in [*pts, *inferred]) + 0.1)
        else:
            ax.text(0.5, 0.5, f"no {label} from the vehicle", transform=ax.transAxes, ha="center", color="0.4")
        ax.set_ylabel(unit)
    for ax in axes:
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8, loc="best")
    from matplotlib.ticker import MaxNLocator

    axes[2].xaxis.set_major_locator(MaxNLocator(integer=True, min_n_ticks=1))
    axes[2].set_xlabel("trial (as numbered on the console)")
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return str(path)


def wind_summary(rec: CampaignRecord) -> str | None:
    """The verdict box's wind line: the vehicle's estimate, or "not estimated by the vehicle" and the wind
    inferred from the trials' telemetry (range over the trials, labelled as inferred); None without a record."""
    cond = [r.entry.cond for r in rec.rows if r.entry.cond]
    if not cond:
        return None
    est = [c["wind_mps"] for c in cond if c.get("wind_mps") is not None]
    inf = [(c["wind_inferred_mps"], c.get("wind_inferred_from_deg")) for c in cond
           if c.get("wind_inferred_mps") is not None]
    if est:
        return f"{min(est):.1f}–{max(est):.1f} m/s (the vehicle's estimate, mean per trial)"
    if not any(c.get("wind_estimated") is False for c in cond):
        return None
    text = "not estimated by the vehicle (no drag fusion or airspeed sensor: the wind it streams reads 0)"
    if inf:
        speeds = [s for s, _ in inf]
        dirs = [d for _, d in inf if d is not None]
        frm = f" from {np.median(dirs):.0f}°" if dirs else ""
        text += (f"; inferred {min(speeds):.1f}–{max(speeds):.1f} m/s{frm} over {len(inf)} trial(s), from the lean "
                 "angle against the ground velocity (a drag-model fit; docs/report.md)")
    return text


def same_condition(rec: CampaignRecord) -> str | None:
    """Every optimiser trial judged against the baseline in its own condition (linear between the baseline
    flights around it, held past the last): the best so far, and the trials unsafe against the first flight only.
    None without a re-flight. With the lap RMS: ``P' = 1 - (1 - P) rms_first / rms_then``; without: P shifted by
    the baseline's drop in P."""
    base = [r for r in rec.rows if r.role in ("baseline", "baseline re-flight") and r.entry.outcome == "ok"]
    opt = [r for r in rec.rows if r.kind == "opt" and r.entry.outcome == "ok"]
    if len(base) < 2 or not opt:
        return None
    t = np.array([r.trial for r in base], dtype=float)
    rms = all(r.entry.rms for r in base) and all(r.entry.rms for r in opt)
    ref = np.array([r.entry.rms if rms else r.entry.P for r in base], dtype=float)
    first = ref[0]
    judged = []
    for r in opt:
        now = float(np.interp(r.trial, t, ref))
        P = r.entry.P
        judged.append((1.0 - (1.0 - P) * first / now if rms else P + (first - now), r))
    best_P, best = max(judged, key=lambda j: j[0])
    drift_only = [r.trial for P, r in judged if r.entry.P < 0 <= P]
    text = (f"judged against the baseline flown in the same condition (interpolated between its {len(base)} "
            f"flights): best trial {best.trial}, P {best_P:+.3f} (as flown {best.entry.P:+.3f})")
    if drift_only:
        text += (f"; trials {', '.join(map(str, drift_only))} were unsafe only against the first baseline flight, "
                 "not in their own condition")
    return text
