"""`ksbo-mav check LOG... --campaign DIR`: does the vehicle still track as it did when its gains were accepted?

Every scored segment of the later flights (any mission with position targets) is compared with the campaign's
confirmation flight. Missions differ in speed, so the measure is the *tracking lag*: RMS 3-D error against the
autopilot's target divided by the RMS speed of the target (s). When a flight's lag exceeds the confirmation's by
more than ``--threshold`` (a factor), it is time to re-tune — an event trigger on the logs, as ETSO (arXiv
2312.08058) triggers re-optimisation when performance drifts.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from ksbo_mav.cli.common import positive_float, to_json


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "check", help="compare later flights' tracking with a campaign's confirmation flight: still fine, or re-tune",
        description="Scores each LOG like `ksbo-mav score` and compares every segment's tracking lag (RMS error "
                    "against the autopilot's target / RMS target speed) with the campaign's confirmation flight of "
                    "the accepted gains. Exit 0 when every flight tracks as it did, 1 when one has drifted past "
                    "--threshold (time to re-tune), 2 on an error.")
    p.add_argument("logs", metavar="LOG", nargs="+", help="flight logs (.tlog, .BIN, .ulg) flown after the tune")
    p.add_argument("--campaign", required=True, metavar="DIR", help="the campaign directory (`ksbo-mav tune DIR`)")
    p.add_argument("--threshold", type=positive_float, default=1.5, metavar="X",
                   help="re-tune when a flight's lag is more than X times the confirmation flight's (default 1.5)")
    p.add_argument("--partial", action="store_true", help="use segments of damaged or cut logs too")
    p.add_argument("--json", action="store_true", help="print the comparison as JSON")
    p.add_argument("--plot", metavar="FILE.png", help="each flight's lag against the confirmation's")
    p.set_defaults(func=run)


def lag(log, seg: dict[str, Any]) -> dict[str, Any]:
    """RMS 3-D error, RMS target speed and their ratio (s) of one scored segment."""
    tg = log.target.window(seg["t_start_s"], seg["t_end_s"])
    err = log.actual.at(tg.t) - tg.pos
    ok = np.all(np.isfinite(err), axis=1)
    rms = float(np.sqrt(np.mean(np.sum(err[ok] ** 2, axis=1)))) if ok.any() else float("nan")
    if tg.vel is not None and np.all(np.isfinite(tg.vel)):
        speed = np.linalg.norm(tg.vel, axis=1)
    else:
        speed = np.linalg.norm(np.gradient(tg.pos, tg.t, axis=0), axis=1) if len(tg) > 2 else np.zeros(1)
    v = float(np.sqrt(np.mean(speed ** 2)))
    return {"segment": seg["segment"], "mode": seg["mode"], "t_start_s": seg["t_start_s"],
            "rms_3d_m": rms, "rms_speed_mps": v, "lag_s": rms / v if v > 0.05 else None}


def confirmation_log(campaign: Path) -> Path:
    from ksbo_mav.campaign.journal import Journal
    from ksbo_mav.campaign.layout import CampaignDir
    from ksbo_mav.errors import InputError

    cd = CampaignDir.at(campaign)
    if not cd.journal.exists():
        raise InputError(f"{campaign} is not a campaign directory (no {cd.journal.name})")
    confirms = [e for e in Journal(cd.journal).of("confirm") if e.outcome.value == "ok"]
    if not confirms:
        raise InputError(f"campaign {campaign} has no completed confirmation flight to compare with")
    tlog = cd.trial_tlog(confirms[-1].trial)
    if not tlog.exists():
        raise InputError(f"the confirmation flight's log {tlog} is missing")
    return tlog


def _segments(path, partial: bool) -> tuple[Any, list[dict[str, Any]]]:
    from ksbo_mav.flightlog import score_file

    result, log, _ = score_file(path, None, partial)
    return log, [lag(log, s) for s in result["segments"]]


def run(args: argparse.Namespace) -> int:
    from ksbo_mav.errors import InputError

    if args.plot:
        from ksbo_mav.flightlog.log_plots import check_plot_path

        check_plot_path(args.plot)
    ref_path = confirmation_log(Path(args.campaign))
    _, ref_segs = _segments(ref_path, True)
    ref = [s for s in ref_segs if s["lag_s"] is not None]
    if not ref:
        raise InputError(f"the confirmation flight {ref_path} has no segment with moving targets to compare with")
    ref_lag = max(ref, key=lambda s: s["rms_speed_mps"])["lag_s"]
    flights, worst = [], 0.0
    for path in args.logs:
        try:
            _, segs = _segments(path, args.partial)
        except InputError as exc:
            flights.append({"log": path, "error": str(exc), "segments": []})
            continue
        for s in segs:
            s["ratio"] = None if s["lag_s"] is None else s["lag_s"] / ref_lag
            worst = max(worst, s["ratio"] or 0.0)
        flights.append({"log": path, "segments": segs})
    if all(f.get("error") for f in flights):
        raise InputError("no flight could be checked: " + "; ".join(f["error"] for f in flights))
    retune = worst > args.threshold
    verdict = (f"time to re-tune: tracking lag up to {worst:.2f}x the confirmation flight's (threshold "
               f"{args.threshold:g}x)" if retune else
               f"still tracks as when the gains were accepted: lag at most {worst:.2f}x the confirmation flight's "
               f"(threshold {args.threshold:g}x)")
    if args.plot:
        _plot(flights, ref_lag, args.threshold, args.plot)
    if args.json:
        print(to_json({"confirmation": {"log": str(ref_path), "lag_s": ref_lag}, "threshold": args.threshold,
                       "retune": retune, "worst_ratio": worst, "flights": flights, "verdict": verdict}))
        return 1 if retune else 0
    print(f"confirmation flight {ref_path}: lag {ref_lag:.3f} s (RMS error / RMS target speed)")
    for f in flights:
        if f.get("error"):
            print(f"{f['log']}: not checked: {f['error']}")
        for s in f["segments"]:
            ratio = "n/a (target not moving)" if s["ratio"] is None else f"{s['ratio']:.2f}x"
            lag_s = "n/a" if s["lag_s"] is None else f"{s['lag_s']:.3f} s"
            print(f"{f['log']} segment {s['segment']} ({s['mode']}): RMS {s['rms_3d_m']:.3f} m at "
                  f"{s['rms_speed_mps']:.2f} m/s, lag {lag_s}, {ratio}")
    print(verdict)
    if args.plot:
        print(f"  plot: {args.plot}")
    return 1 if retune else 0


def _plot(flights: list[dict[str, Any]], ref_lag: float, threshold: float, path: str) -> None:
    from ksbo_mav.flightlog.log_plots import _save
    from ksbo_mav.plotting import pyplot

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 4), constrained_layout=True)
    labels, values = [], []
    for f in flights:
        for s in f["segments"]:
            if s["lag_s"] is not None:
                labels.append(f"{Path(f['log']).name}:{s['segment']}")
                values.append(s["lag_s"])
    ax.bar(range(len(values)), values, color=["tab:red" if v > threshold * ref_lag else "tab:blue" for v in values])
    ax.axhline(ref_lag, color="k", lw=1.0, label="confirmation flight")
    ax.axhline(threshold * ref_lag, color="tab:red", lw=1.0, ls="--", label=f"re-tune above ({threshold:g}x)")
    ax.set_xticks(range(len(values)), labels, rotation=30, ha="right", fontsize=7)
    ax.set_ylabel("tracking lag (s): RMS error / RMS target speed")
    ax.legend(fontsize=7)
    _save(fig, Path(path))
