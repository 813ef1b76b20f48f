"""The report's view of a vehicle that changes: the baseline flights (first and re-flights) and the conditions
each trial flew in (wind, battery voltage), over the campaign, and the drift test's verdict in plain words."""

from __future__ import annotations

import json
from pathlib import Path

from ksbo_mav.campaign.trial_rows import CampaignRecord
from ksbo_mav.plotting import pyplot

#: Where a campaign keeps the drift test's verdict once it fired (read by the report).
DRIFT_FILE = "drift.json"


def save_drift(root: Path, message: str, mode: str) -> None:
    """Keep the drift test's message with the campaign (the report says it)."""
    (Path(root) / DRIFT_FILE).write_text(json.dumps({"message": message, "on_drift": mode}) + "\n")


def load_drift(root: Path) -> str | None:
    p = Path(root) / DRIFT_FILE
    try:
        doc = json.loads(p.read_text())
    except (OSError, ValueError):
        return None
    then = ("campaign stopped" if doc.get("on_drift") == "stop"
            else "campaign went on, scored against the re-flown baseline")
    return f"{doc.get('message', '')} ({then})"


def plot_conditions(rec: CampaignRecord, path: Path) -> str | None:
    """Baseline flights (lap RMS, else P) and each trial's wind and battery voltage, by trial; None when the
    campaign re-flew no baseline and recorded no conditions."""
    base = [r for r in rec.rows if r.role in ("baseline", "baseline re-flight") and r.entry.outcome == "ok"]
    cond = [r for r in rec.rows if r.entry.cond]
    wind = [(r.trial, r.entry.cond["wind_mps"]) for r in cond if r.entry.cond.get("wind_mps") is not None]
    volt = [(r.trial, r.entry.cond["voltage_v"]) for r in cond if r.entry.cond.get("voltage_v") is not None]
    if len(base) < 2 and not wind and not volt:
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
        if pts:
            ax.plot([t for t, _ in pts], [v for _, v in pts], ".", color="C1", label=label)
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
