"""`ksbo-mav compare A B`: the same kind of segment in two flight logs (before/after a tune), side by side."""

from __future__ import annotations

import argparse
from typing import Any

from ksbo_mav.cli.common import positive_int, to_json


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "compare", help="compare the tracking of two flight logs (before/after a tune), side by side, with a plot",
        description="Scores both logs like `ksbo-mav score` (any of .tlog/.BIN/.ulg, mixed freely) and puts the "
                    "same segment type side by side: the profile's figure-8 when both logs have one (per lap), "
                    "else the longest tracking segment of each. Two validation flights' tlogs (the same "
                    "manoeuvre) give their figures side by side.")
    p.add_argument("a", metavar="A", help="first log (e.g. before the tune)")
    p.add_argument("b", metavar="B", help="second log (e.g. after the tune)")
    p.add_argument("--profile", default=None, help="profile whose mission applies (default: per log's autopilot)")
    p.add_argument("--segment-a", type=positive_int, default=None, metavar="N", help="use segment N of A")
    p.add_argument("--segment-b", type=positive_int, default=None, metavar="N", help="use segment N of B")
    p.add_argument("--partial", action="store_true", help="accept logs cut inside a segment")
    p.add_argument("--json", action="store_true", help="print the comparison as JSON")
    p.add_argument("--plot", metavar="FILE.png", help="both trajectories and their errors over time")
    p.set_defaults(func=run)


def pick(result: dict[str, Any], want_f8: bool) -> dict[str, Any]:
    segs = result["segments"]
    if want_f8:
        return next(s for s in segs if s["figure8"])
    return max(segs, key=lambda s: s["duration_s"])


def _rows(sa: dict[str, Any], sb: dict[str, Any]) -> list[tuple[str, Any, Any]]:
    rows = []
    fa, fb = sa["figure8"], sb["figure8"]
    if fa and fb:
        for k in range(max(len(fa["laps"]), len(fb["laps"]))):
            la = fa["laps"][k] if k < len(fa["laps"]) else None
            lb = fb["laps"][k] if k < len(fb["laps"]) else None
            for ref in ("vs_target", "vs_reference"):
                for key in ("h_rms_m", "h_max_m", "v_rms_m", "v_max_m"):
                    rows.append((f"lap {k + 1} {ref.replace('vs_', 'vs ')} {key[:-2].replace('_', ' ')} (m)",
                                 la[ref][key] if la else None, lb[ref][key] if lb else None))
        rows.append(("P", fa["score"].get("P"), fb["score"].get("P")))
        rows.append(("lap-2 RMS (m)", fa["score"].get("rms_lap2_m"), fb["score"].get("rms_lap2_m")))
    else:
        for key in ("h_rms_m", "h_max_m", "v_rms_m", "v_max_m"):
            rows.append((f"vs target {key[:-2].replace('_', ' ')} (m)", sa["vs_target"][key], sb["vs_target"][key]))
    return rows


def by_segment(ra: dict[str, Any], rb: dict[str, Any]) -> list[dict[str, Any]]:
    """The two logs' segments lined up in order (segment k of A beside segment k of B)."""
    sa, sb = ra["segments"], rb["segments"]
    out = []
    for k in range(max(len(sa), len(sb))):
        a = sa[k] if k < len(sa) else None
        b = sb[k] if k < len(sb) else None
        row: dict[str, Any] = {"pair": k + 1}
        for side, s in (("a", a), ("b", b)):
            row[side] = None if s is None else {
                "segment": s["segment"], "mode": s["mode"], "duration_s": s["duration_s"],
                "h_rms_m": s["vs_target"]["h_rms_m"], "v_rms_m": s["vs_target"]["v_rms_m"],
                "spectrum_peak_hz": (s.get("spectrum") or {}).get("peak_hz"),
                "P": (s["figure8"] or {}).get("score", {}).get("P") if s["figure8"] else None}
        out.append(row)
    return out


def _by_segment_lines(rows: list[dict[str, Any]]) -> list[str]:
    lines = ["segment by segment (vs target RMS h/v m, error spectrum peak):"]
    for r in rows:
        cells = []
        for side in ("a", "b"):
            s = r[side]
            cells.append("-" if s is None else
                         f"{side.upper()}{s['segment']} {s['mode']} {s['duration_s']:.0f} s h {s['h_rms_m']:.3f} "
                         f"v {s['v_rms_m']:.3f}" + (f" peak {s['spectrum_peak_hz']:.2f} Hz"
                                                    if s["spectrum_peak_hz"] is not None else ""))
        lines.append(f"  {r['pair']}: {cells[0]}  |  {cells[1]}")
    return lines


def run(args: argparse.Namespace) -> int:
    from ksbo_mav.errors import InputError
    from ksbo_mav.flightlog import score_file

    from ksbo_mav.mav.validation.manoeuvre_log import compare_validation, format_comparison, is_validation_tlog

    if all(is_validation_tlog(p) for p in (args.a, args.b)):  # two validation flights: their figures side by side
        c = compare_validation(args.a, args.b)
        print(to_json(c) if args.json else "\n".join(format_comparison(c)))
        return 0
    if args.plot:
        from ksbo_mav.flightlog.log_plots import check_plot_path

        check_plot_path(args.plot)
    ra, log_a, mission = score_file(args.a, args.profile, args.partial, args.segment_a)
    rb, log_b, _ = score_file(args.b, args.profile, args.partial, args.segment_b)
    both_f8 = any(s["figure8"] for s in ra["segments"]) and any(s["figure8"] for s in rb["segments"])
    sa, sb = pick(ra, both_f8), pick(rb, both_f8)
    if not both_f8 and (sa["figure8"] or sb["figure8"]):
        sa = dict(sa, figure8=None)
        sb = dict(sb, figure8=None)
    kind = "figure-8" if both_f8 else "tracking segment (no figure-8 in both)"
    rows = _rows(sa, sb)
    if args.plot:
        from ksbo_mav.flightlog.log_plots import plot_compare

        plot_compare([(f"A: {args.a}", log_a, sa), (f"B: {args.b}", log_b, sb)], mission, args.plot)
    if args.json:
        print(to_json({"kind": kind, "a": {"log": args.a, "segment": sa}, "b": {"log": args.b, "segment": sb},
                       "rows": [{"metric": m, "a": a, "b": b} for m, a, b in rows],
                       "by_segment": by_segment(ra, rb)}))
        return 0
    if not rows:
        raise InputError("nothing to compare")
    print(f"compare ({kind}): A = {args.a} segment {sa['segment']} ({sa['mode']}), "
          f"B = {args.b} segment {sb['segment']} ({sb['mode']})")
    w = max(len(m) for m, _, _ in rows)
    print(f"  {'metric':<{w}}  {'A':>9}  {'B':>9}  {'B-A':>9}")
    for m, a, b in rows:
        fa = "n/a" if a is None else f"{a:.4f}"
        fb = "n/a" if b is None else f"{b:.4f}"
        d = "" if a is None or b is None else f"{b - a:+.4f}"
        print(f"  {m:<{w}}  {fa:>9}  {fb:>9}  {d:>9}")
    if len(ra["segments"]) > 1 or len(rb["segments"]) > 1:
        print("\n".join(_by_segment_lines(by_segment(ra, rb))))
    if args.plot:
        print(f"  plot: {args.plot}")
    return 0
