"""`ksbo-mav score FILE.tlog`: recompute a trial's P(a) from its tlog alone (exactly the live score)."""

from __future__ import annotations

import argparse

from ksbo_mav.cli.common import to_json


def add_parser(subparsers) -> None:
    p = subparsers.add_parser("score", help="recompute P(a) of a trial from its .tlog",
                              description="Replays a trial tlog (both directions) and computes P(a) from the "
                                          "logged telemetry and the logged setpoints, as the tuner did live.")
    p.add_argument("tlog", metavar="FILE.tlog")
    p.add_argument("--profile", default=None,
                   help="profile whose mission/[score] constants apply (default: sim-planar for the planar "
                        "figure-8, ardupilot-copter for the horizontal one)")
    p.add_argument("--json", action="store_true", help="print the score as JSON")
    p.add_argument("--plot", metavar="FILE.png", help="plot the flown trajectory against the logged reference")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ksbo_mav.errors import InputError
    from ksbo_mav.mav.mission import Mission
    from ksbo_mav.mav.tlog import read_tlog
    from ksbo_mav.mav.trajectory import trajectory_from_tlog
    from ksbo_mav.profiles import load_profile

    traj, info, rec = trajectory_from_tlog(read_tlog(args.tlog))
    profile = load_profile(args.profile or ("sim-planar" if rec.kind == "figure8-xz" else "ardupilot-copter"))
    mission = Mission.from_profile(profile)
    if (mission.kind, mission.steps, mission.window[0], mission.dt_ms) != (rec.kind, rec.n, rec.w, rec.dt):
        raise InputError(f"the tlog's trial ({rec.kind}, {rec.n} steps of {rec.dt} ms, scored from {rec.w}) does not "
                         f"match profile {profile.name}'s mission; pass the campaign's --profile")
    score = mission.score(traj)
    if info["outcome"] != "ok":  # the live tuner counts every aborted trial as unsafe
        score["P"] = min(float(score["P"]), -1.0 / rec.n)
        score["safe"] = False
    if args.plot:
        from ksbo_mav.plotting import plot_trajectories

        plot_trajectories([traj], [f"flown (P={score['P']:.4f})"], args.plot, title=str(args.tlog))
    if args.json:
        print(to_json({"tlog": args.tlog, "score": score, "trial": info}))
        return 0
    detail = (f"J^Q = {score['JQ'] if score['JQ'] is None else round(score['JQ'], 6)}" if "JQ" in score
              else f"lap-2 RMS = {score['rms_lap2_m']} m")
    print(f"{args.tlog}: P(a) = {score['P']:.6f}  {detail}  L = {score['L']}/{score['L_expected']}  "
          f"outcome {info['outcome']}  {'safe' if score['safe'] else 'UNSAFE'}")
    filled = sum(info["filled"].values())
    if filled:
        print(f"  {filled} sample value(s) interpolated across lost packets")
    if args.plot:
        print(f"  plot: {args.plot}")
    return 0
