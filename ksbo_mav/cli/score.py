"""`ksbo-mav score FILE`: score any flight log — ArduPilot DataFlash .BIN, PX4 .ulg, any ground station's .tlog.

The format is detected from the file's content. A trial tlog written by this tool (it holds the ``ksbo f8`` trial
markers) is re-scored exactly as the tuner scored it live, plus the segment analysis below; any other
log is split into the segments where the vehicle tracked position targets (guided / auto / offboard) and each is
scored against the autopilot's own logged target and, for the profile's figure-8, per lap against the analytic
reference as well, with the profile's P (:mod:`ksbo_mav.flightlog`). A validation flight's tlog (its ``ksbo val``
markers) gives that flight's figures again (:mod:`ksbo_mav.mav.validation.manoeuvre_log`).
"""

from __future__ import annotations

import argparse
import mmap
from pathlib import Path
from typing import Any

from ksbo_mav.cli.common import positive_float, positive_int, to_json


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "score", help="score a flight log (.tlog, ArduPilot .BIN, PX4 .ulg): tracking errors per segment and lap",
        description="Finds the segments where the vehicle tracked position targets (GUIDED/AUTO, OFFBOARD/"
                    "MISSION) and scores each: RMS and max tracking error (horizontal, vertical) against the "
                    "autopilot's logged target; for the profile's figure-8 also per lap and against the analytic "
                    "reference, with the profile's P. A trial tlog written by `ksbo-mav tune` is re-scored "
                    "exactly as live; a validation flight's tlog gives its figures (steps, hold, mission) "
                    "again. The format is detected from the content, not the file name.")
    p.add_argument("log", metavar="FILE", help=".tlog, DataFlash .BIN or ULog .ulg")
    p.add_argument("--profile", default=None,
                   help="profile whose mission/[score] apply (default: px4-copter for PX4 logs, ardupilot-copter "
                        "otherwise; sim-planar for the planar trial tlogs)")
    p.add_argument("--segment", type=positive_int, default=None, metavar="N", help="score only segment N (1-based)")
    p.add_argument("--rms-ref", type=positive_float, default=None, metavar="M",
                   help="the campaign's baseline lap-2 RMS (m) that P is relative to (default: the trial's own "
                        "marker when logged, else the flight itself)")
    p.add_argument("--partial", action="store_true",
                   help="score a log that is cut inside a segment (what is there), instead of refusing it")
    p.add_argument("--json", action="store_true", help="print the scores as JSON")
    p.add_argument("--plot", metavar="FILE.png", help="plot trajectory vs target and the errors over time")
    p.set_defaults(func=run)


def is_trial_tlog(path: str | Path) -> bool:
    """A tlog of one of our own trials (it carries the STATUSTEXT trial markers)."""
    with open(path, "rb") as fh:
        try:
            with mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as mm:
                return mm.find(b"ksbo f8") >= 0
        except ValueError:  # empty file
            return False


def run(args: argparse.Namespace) -> int:
    from ksbo_mav.flightlog import detect_format

    if args.plot:
        from ksbo_mav.flightlog.log_plots import check_plot_path

        check_plot_path(args.plot)
    fmt = detect_format(args.log)
    if fmt == "tlog" and is_trial_tlog(args.log):
        return _run_trial(args)
    if fmt == "tlog":
        from ksbo_mav.mav.validation.manoeuvre_log import format_validation, is_validation_tlog, \
            score_validation_tlog

        if is_validation_tlog(args.log):  # a validation flight's figures, re-measured from its packets
            result = score_validation_tlog(args.log)
            print(to_json(result) if args.json else "\n".join(format_validation(result)))
            return 0
    return _run_generic(args)


def _run_generic(args: argparse.Namespace, warning: str | None = None) -> int:
    from ksbo_mav.flightlog import score_file

    result, log, mission = score_file(args.log, args.profile, args.partial, args.segment, args.rms_ref)
    if warning:
        result["warnings"].insert(0, warning)
    if args.plot:
        _plot(log, result, mission, args.plot)
    if args.json:
        print(to_json(result))
        return 0
    print("\n".join(format_result(result)))
    if args.plot:
        print(f"  plot: {args.plot}")
    return 0


def _plot(log, result: dict[str, Any], mission, path: str) -> None:
    from ksbo_mav.flightlog.log_plots import plot_segment

    segs = result["segments"]
    seg = next((s for s in segs if s["figure8"]), segs[0])
    plot_segment(log, seg, mission, path)


def _f(x: Any, nd: int = 3) -> str:
    return "n/a" if x is None else f"{x:.{nd}f}"


def _stats(d: dict[str, Any]) -> str:
    return (f"h {_f(d['h_rms_m'])}/{_f(d['h_max_m'])} v {_f(d['v_rms_m'])}/{_f(d['v_max_m'])}")


def format_result(r: dict[str, Any]) -> list[str]:
    from ksbo_mav.flightlog.detect import FORMATS

    mb = (r.get("bytes") or 0) / 1e6
    ver = f", {r['version']}" if r.get("version") else ""
    lines = [f"{r['log']}: {FORMATS[r['format']]}, {r['autopilot']}{ver}, {mb:.1f} MB",
             f"  flown: {r['actual_source']}; target: {r['target_source']}"]
    for s in r["segments"]:
        lines.append(f"segment {s['segment']}: {s['mode']} t={s['t_start_s']:.1f}..{s['t_end_s']:.1f} s "
                     f"({s['duration_s']:.1f} s)  vs target (RMS/max m): {_stats(s['vs_target'])}")
        sp = s.get("spectrum")
        if sp:
            lines.append(f"  error spectrum: horizontal peak {sp['peak_amp_m']:.3f} m at {sp['peak_hz']:.2f} Hz, "
                         f"vertical {sp['peak_v_amp_m']:.3f} m at {sp['peak_v_hz']:.2f} Hz")
        if s.get("note"):
            lines.append(f"  starts where {s['note']}")
        if not s.get("figure8s"):
            lines.append("  no figure-8 of the profile's mission in this segment")
        for f8 in s.get("figure8s", []):
            lines.extend(_figure8_lines(f8))
    for sk in r.get("skipped_segments", []):
        lines.append(f"skipped {sk['mode']} t={sk['t_start_s']:.1f}..{sk['t_end_s']:.1f} s: {sk['reason']}")
    for w in r["warnings"]:
        lines.append(f"warning: {w}")
    return lines


def _figure8_lines(f8: dict[str, Any]) -> list[str]:
    off = ", ".join(f"{x:.2f}" for x in f8["offset_m"])
    lines = [f"  figure-8 ({f8['profile']} mission) from t={f8['t0_s']:.3f} s, {f8['laps_flown']:.2f} laps, "
             f"offset NED ({off}) m" + ("  [trial marker]" if f8["marker"] else "")]
    for lap in f8["laps"]:
        motors = "" if lap.get("motor_osc_us") is None else f", motor oscillation {lap['motor_osc_us']:.1f} us"
        lines.append(f"    lap {lap['lap']}: vs target {_stats(lap['vs_target'])}  |  vs reference "
                     f"{_stats(lap['vs_reference'])}  (RMS/max m){motors}")
    sc = f8["score"]
    if sc.get("P") is None:
        lines.append(f"    P: n/a ({sc.get('reason')})")
    else:
        lines.append(f"    P = {sc['P']:.4f}  (lap-2 RMS {_f(sc.get('rms_lap2_m'))} m, reference "
                     f"{_f(sc.get('rms_ref_m'))} m, {'safe' if sc.get('safe') else 'UNSAFE'})"
                     + (f"  incomplete: {sc['incomplete']}" if sc.get("incomplete") else ""))
    return lines


def _run_trial(args: argparse.Namespace) -> int:
    """A trial tlog of our own: the exact live score, plus the generic segment analysis."""
    from ksbo_mav.errors import InputError
    from ksbo_mav.mav.mission import Mission
    from ksbo_mav.mav.tlog import read_tlog
    from ksbo_mav.mav.trajectory import trajectory_from_tlog
    from ksbo_mav.profiles import load_profile

    try:
        records = read_tlog(args.log)
    except InputError as exc:  # damaged: the exact live score needs every record; score it as any flight log
        return _run_generic(args, warning=f"not re-scored as a trial (the exact score needs the intact file: "
                                          f"{str(exc).split(': ', 1)[-1]}); scored as a flight log")
    traj, info, rec = trajectory_from_tlog(records)
    name = args.profile
    if name is None and rec.kind == "figure8-xz":
        name = "sim-planar"
    elif name is None:  # the 3-D figure-8: the profile of the vehicle's autopilot (HEARTBEAT)
        from ksbo_mav.flightlog import default_profile, read_log

        try:
            name = default_profile(read_log(args.log, partial=True))
        except InputError:
            name = "ardupilot-copter"
    profile = load_profile(name)
    mission = Mission.from_profile(profile)
    if (mission.kind, mission.steps, mission.window[0], mission.dt_ms) != (rec.kind, rec.n, rec.w, rec.dt):
        raise InputError(f"the tlog's trial ({rec.kind}, {rec.n} steps of {rec.dt} ms, scored from {rec.w}) does not "
                         f"match profile {profile.name}'s mission; pass the campaign's --profile")
    rms_ref = args.rms_ref if args.rms_ref is not None else getattr(rec, "rms_ref", None)
    score = mission.score(traj, rms_ref=rms_ref, smooth=mission.lap_smoothness(rec.t0, rec.att, rec.motors),
                          rough_ref=rec.rough_ref)
    if info["outcome"] != "ok":  # the live tuner counts every aborted trial as unsafe
        score["P"] = min(float(score["P"]), -1.0 / rec.n)
        score["safe"] = False
    segments: dict[str, Any] = {}
    if rec.kind == "figure8-ne":
        from ksbo_mav.flightlog import score_file

        try:
            segments, _, _ = score_file(args.log, profile.name, True, args.segment, rms_ref)
        except InputError as exc:
            segments = {"error": str(exc)}
    if args.plot:
        from ksbo_mav.plotting import plot_trajectories, scored_span

        plot_trajectories([traj], [f"flown (P={score['P']:.4f})"], args.plot, title=str(args.log), kind=rec.kind,
                          scored=scored_span(info))
    if args.json:
        print(to_json({"tlog": args.log, "score": score, "trial": info, "analysis": segments or None}))
        return 0
    detail = (f"J^Q = {score['JQ'] if score['JQ'] is None else round(score['JQ'], 6)}" if "JQ" in score
              else f"lap-2 RMS = {score['rms_lap2_m']} m")
    print(f"{args.log}: P(a) = {score['P']:.6f}  {detail}  L = {score['L']}/{score['L_expected']}  "
          f"outcome {info['outcome']}  {'safe' if score['safe'] else 'UNSAFE'}")
    if score.get("rough_dps") is not None:
        ref = score.get("rough_ref_dps")
        print(f"  roughness {score['rough_dps']:.2f} deg/s (body rates above the cutoff; baseline "
              f"{'not in the log' if ref is None else f'{ref:.2f}'}), smoothness term {score['smooth_penalty']:.3f}, "
              f"largest tilt {score['tilt_max_deg']:.1f} deg")
    elif score.get("rough_note"):
        print(f"  roughness not measured: {score['rough_note']}")
    if score.get("motor_osc_us") is not None:
        print(f"  motor oscillation {score['motor_osc_us']:.1f} us (SERVO_OUTPUT_RAW above the cutoff, per motor)")
    elif score.get("motor_note"):
        print(f"  motor oscillation not measured: {score['motor_note']}")
    filled = sum(info.get("filled", {}).values())
    if filled:
        print(f"  {filled} sample value(s) interpolated across lost packets")
    if segments and "segments" in segments:
        print("\n".join("  " + line for line in format_result(segments)[2:]))
    if args.plot:
        print(f"  plot: {args.plot}")
    return 0
