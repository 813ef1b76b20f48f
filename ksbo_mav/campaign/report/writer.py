"""Campaign report: plots and one self-contained page (report/index.html) from a campaign directory.

Everything is read back from disk (settings, journal, trial records, tlogs), so the report can be regenerated
after the fact (``ksbo-mav report DIR``) and shows what was logged, not what the tuner believed in memory. Trial
numbers are the ones the console printed (0-based, every flown trial counted: baseline, prior, optimiser,
confirmation and interrupted trials alike).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ksbo_mav.campaign.box_edge import EdgeHit, edge_hits
from ksbo_mav.campaign.layout import CampaignDir
from ksbo_mav.campaign.report.plots import plot_convergence, plot_gains, plot_safety
from ksbo_mav.campaign.report.rows import CampaignRecord, read_campaign, trajectory

#: How many of the best flown trials back up (or not) a box-edge note.
NEAR_BEST = 5


def load_result(d: CampaignDir) -> dict[str, Any] | None:
    """result.json, or None while the campaign has not finished."""
    try:
        return json.loads(d.result.read_text())
    except (OSError, json.JSONDecodeError):
        return None


def campaign_profile(settings: dict[str, Any]) -> Any | None:
    """The profile the campaign flew (the file it named, else the detected one); None if it cannot be loaded."""
    from ksbo_mav.errors import KsboError
    from ksbo_mav.profiles import load_profile

    try:
        return load_profile(settings["config"].get("profile") or settings["profile"])
    except (KsboError, OSError, KeyError, AttributeError):
        return None


@dataclass(frozen=True)
class BoxGrowth:
    """One growth of the search box, as the console said it (a line of the report's box notes)."""

    text: str

    def message(self) -> str:
        return self.text


def grown_record(rec: CampaignRecord, result: dict[str, Any] | None, profile: Any
                 ) -> tuple[CampaignRecord, np.ndarray | None, list[BoxGrowth]]:
    """The campaign record ``rec`` with its final search box (result.json's ``box`` where it grew), the limits it
    could grow to in the vehicle's units (the profile's box; None without the profile), and each growth."""
    from ksbo_mav.campaign.search import growth_message

    fits = profile is not None and profile.dim == len(rec.names)
    limits = profile.bounds / rec.scale[:, None] if fits else None
    box = (result or {}).get("box") or {}
    if not box.get("bounds"):
        return rec, limits, []
    rec = dataclasses.replace(rec, settings={**rec.settings, "bounds": box["bounds"]})
    lines = [BoxGrowth(growth_message(g, profile)) for g in box.get("growth", []) if fits]
    return rec, limits, lines


def box_edges(rec: CampaignRecord, best_x: Any, profile: Any | None, limits: Any = None) -> list[EdgeHit]:
    """Where the recommendation ``best_x`` (optimiser units) touches the search box, in the vehicle's units
    (``limits``: how far the box could go; default the profile's box)."""
    if limits is None and profile is not None and profile.dim == len(rec.names):
        limits = profile.bounds / rec.scale[:, None]
    good = sorted((r for r in rec.rows if r.kind in ("opt", "prior") and r.entry.outcome == "ok" and r.P >= 0),
                  key=lambda r: -r.P)[:NEAR_BEST]
    near = np.array([[r.values[n] for n in rec.names] for r in good]).reshape(-1, len(rec.names))
    return edge_hits(rec.to_params(best_x), rec.bounds, rec.names, limits=limits, near_best=near)


def box_edge_lines(d: CampaignDir | str | Path, result: dict[str, Any] | None = None) -> list[str]:
    """The box-edge notes of a finished campaign, one line each (none when the recommendation is inside)."""
    d = d if isinstance(d, CampaignDir) else CampaignDir.at(d)
    result = result if result is not None else load_result(d)
    if not result:
        return []
    rec = read_campaign(d, rms=False)
    profile = campaign_profile(rec.settings)
    rec, limits, moves = grown_record(rec, result, profile)
    return [m.message() for m in moves] + [h.message() for h in box_edges(rec, result["best"]["x"], profile, limits)]


def simulator_wind(d: CampaignDir, rec: CampaignRecord) -> str | None:
    """What a simulated vehicle's own parameters (as the snapshot holds them) say blows at the mission's height: the
    truth the inferred wind is read against on a bench (:func:`~ksbo_mav.mav.wind_source.simulated_wind`)."""
    from ksbo_mav.mav.params import load_snapshot
    from ksbo_mav.mav.wind_source import simulated_wind

    try:
        params = {n: v for n, (v, _) in load_snapshot(d.snapshot).params.items()}
    except Exception:  # noqa: BLE001 - no snapshot, no simulator figure
        return None
    height = float((rec.settings.get("mission") or {}).get("center_up", 10.0))
    blown = simulated_wind(params, height)
    if blown is None:
        return None
    speed, frm, how = blown
    return (f"the simulator blows {speed:.1f} m/s from {frm:.0f}° at the mission's {height:g} m ({how}; as the "
            "snapshot holds it)")


def _trajectory_plot(rec: CampaignRecord, path: Path) -> str | None:
    """Baseline against the last completed confirmation flight, in the mission's frame."""
    from ksbo_mav.plotting import plot_trajectories, scored_span

    base = [r for r in rec.of("baseline") if r.entry.outcome == "ok"]
    tuned = [r for r in rec.of("confirmation") if r.entry.outcome == "ok"]
    if not base or not tuned:
        return None
    flights = [(base[0], "baseline"), (tuned[-1], "tuned")]
    trajs, labels, info = [], [], {}
    for row, name in flights:
        traj, info = trajectory(row.entry.record)
        trajs.append(traj)
        rms = f", lap RMS {row.rms:.3f} m" if row.rms is not None else ""
        labels.append(f"{name}, trial {row.trial} (P={row.P:.3f}{rms})")
    kind = info["kind"]
    view = "north / east, seen from above" if kind == "figure8-ne" else "north / up, seen from the side"
    return str(plot_trajectories(trajs, labels, path, title=f"Figure-8 over MAVLink, before / after ({view})",
                                 kind=kind, scored=scored_span(info)))


def _plot_inputs(d: CampaignDir, best_x: Any, limits: Any, hits: list[EdgeHit], box: Any = None) -> str:
    """A digest of everything the plots are drawn from: the settings, the journal (which names every trial record
    and tlog, each written once), the final search box, the recommendation, the limits and the edge hits."""
    digest = hashlib.sha256()
    for path in (d.config, d.journal):
        digest.update(path.read_bytes() if path.is_file() else b"-")
    digest.update(repr((best_x, None if limits is None else np.asarray(limits).tolist(), hits, box)).encode())
    return digest.hexdigest()


def _draw(d: CampaignDir, rec: CampaignRecord, best_x: Any, limits: Any, hits: list[EdgeHit],
          fresh: bool = False) -> dict[str, str]:
    """The report's plots drawn; {name: path, or "none" where there is nothing to show}. Plots drawn before from
    the same inputs are kept (drawing them takes seconds; a campaign writes its report before and after the
    validation flights, which change none of them) unless ``fresh``."""
    from ksbo_mav.campaign.report.conditions import plot_conditions

    key, stamp = _plot_inputs(d, best_x, limits, hits, rec.settings.get("bounds")), d.report / "plots.json"
    if not fresh:
        try:
            kept = json.loads(stamp.read_text())
            drawn = {k: v if v == "none" else str(d.report / v) for k, v in kept["plots"].items()}
            if kept["inputs"] == key and all(p == "none" or Path(p).is_file() for p in drawn.values()):
                return drawn
        except (OSError, ValueError, KeyError, TypeError, AttributeError):
            pass
    stamp.unlink(missing_ok=True)
    paths: dict[str, str] = {
        "convergence": plot_convergence(rec, d.report_plot("convergence")),
        "gains": plot_gains(rec, None if best_x is None else rec.to_params(best_x), limits, hits,
                            d.report_plot("gains")),
    }
    traj = _trajectory_plot(rec, d.report_plot("trajectory"))
    if traj:
        paths["trajectory"] = traj
    paths["safety"] = plot_safety(rec, d.report_plot("safety")) or "none"
    paths["conditions"] = plot_conditions(rec, d.report_plot("conditions")) or "none"
    stamp.write_text(json.dumps({"inputs": key, "plots": {k: v if v == "none" else Path(v).name
                                                          for k, v in paths.items()}}))
    return paths


#: The report's plots, by the name of their file under report/.
PLOT_NAMES = ("convergence", "gains", "trajectory", "safety", "conditions")


def write_report(d: CampaignDir | str | Path, profile: Any = None, result: dict[str, Any] | None = None,
                 draw: bool = True, fresh: bool = False) -> dict[str, str]:
    """Write the report's plots and its page under ``d``/report; returns {name: path}. Without ``draw`` (a stop:
    it must be quick, and drawing takes seconds to minutes on a loaded computer) only the page is written, with the
    plots as last drawn, if any, and a line saying that ``ksbo-mav report DIR`` draws them anew.

    Plots: convergence.png, gains.png, trajectory.png (when the baseline and a confirmation flight completed) and
    safety.png (only when a trial was unsafe, aborted, crashed or interrupted; else {"safety": "none"}); the page
    index.html embeds them. ``result``: the campaign's summary (default: result.json); ``profile``: the vehicle
    profile (default: the one the campaign names), for the profile's own gain limits; ``fresh``: draw the plots
    even where the ones on disk were drawn from the same inputs.
    """
    from ksbo_mav.campaign.drift import load_drift
    from ksbo_mav.campaign.report.conditions import same_condition, wind_summary
    from ksbo_mav.campaign.report.page import write_page
    from ksbo_mav.campaign.report.validation_table import validation_section, verdict_lines
    from ksbo_mav.campaign.validation_log import ValidationJournal

    d = d if isinstance(d, CampaignDir) else CampaignDir.at(d)
    d.report.mkdir(parents=True, exist_ok=True)
    rec = read_campaign(d)
    result = result if result is not None else load_result(d)
    if result is not None and d.link.is_file():  # the link check's figures, for the verdict
        try:
            result = {**result, "link": json.loads(d.link.read_text())[-1]}
        except (OSError, ValueError, IndexError):
            pass
    profile = profile if profile is not None else campaign_profile(rec.settings)
    best_x = ((result or {}).get("best") or {}).get("x")  # none when the campaign recommended nothing
    rec, limits, moves = grown_record(rec, result, profile)
    hits = box_edges(rec, best_x, profile, limits) if best_x is not None else []
    if draw:
        paths = _draw(d, rec, best_x, limits, hits, fresh)
    else:
        paths = {k: str(d.report_plot(k)) for k in PLOT_NAMES if d.report_plot(k).is_file()}
        result = {**(result or {}), "plots_note": f"Plots {'as last drawn, before this stop' if paths else 'not drawn'}"
                  f": `ksbo-mav report {d.root}` draws them from every flight on disk."}
    drift, same = load_drift(d), same_condition(rec)
    wind = wind_summary(rec)
    blown = simulator_wind(d, rec)
    if wind and blown:
        wind = f"{wind}; {blown}"
    if wind:
        result = {**(result or {}), "wind": wind}
    flown = ValidationJournal(d.validation_journal).entries
    if flown:
        result = {**(result or {}), "validation_lines": verdict_lines(flown),
                  "validation_html": validation_section(flown)}
    from ksbo_mav.campaign.stops import read_stop

    stop = read_stop(d)
    if stop is not None:
        result = {**(result or {}), "stopped": {"reason": stop.reason, "command": stop.command}}
    if drift:
        result = {**(result or {}), "drift": drift}
    if same:
        result = {**(result or {}), "same_condition": same}
    paths["page"] = str(write_page(d.report_page, rec, result, [*moves, *hits], paths))
    return paths
