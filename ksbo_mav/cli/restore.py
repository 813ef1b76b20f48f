"""`ksbo-mav restore SNAPSHOT`: put the snapshot's gains back on the vehicle and verify them by a fresh read."""

from __future__ import annotations

import argparse

from ksbo_mav.cli.common import add_connection_args, endpoint_from_args


def add_parser(subparsers) -> None:
    p = subparsers.add_parser("restore", help="write a snapshot's gains back to the vehicle (verified)",
                              description="Works from disk alone, also after the tuner crashed: SNAPSHOT is a "
                                          "campaign directory or its snapshot/vehicle.json. On an unfinished "
                                          "campaign (the tuner killed, or stopped) it also writes the report of "
                                          "what was flown and prints the one command that continues it.")
    p.add_argument("snapshot", metavar="SNAPSHOT")
    add_connection_args(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ksbo_mav.campaign import restore_snapshot

    endpoint = endpoint_from_args(args)
    values = restore_snapshot(args.snapshot, endpoint, log=lambda s: print(s), timeout=args.timeout,
                              sysid=args.sysid, compid=args.compid)
    for name, value in values.items():
        print(f"  {name:<16} {value:.7g}")
    print(f"restored {len(values)} gain(s) from {args.snapshot}; verified by a fresh read")
    from pathlib import Path

    from ksbo_mav.campaign import CampaignDir

    if Path(args.snapshot).is_dir():
        after_restore(CampaignDir.at(args.snapshot), endpoint)
    return 0


def after_restore(d, endpoint) -> None:
    """On an unfinished campaign (a tuner killed outright, or stopped): the report of what was flown and the one
    command that continues; a stop nobody recorded (``kill -9``, a power cut) is recorded now."""
    from ksbo_mav.campaign.ending import rewrite_report
    from ksbo_mav.campaign.stops import EXIT, continue_command, next_phase, read_stop, write_stop

    phase = next_phase(d) if d.config.is_file() else None
    if phase is None:
        return
    command = continue_command(d, endpoint, phase)
    if read_stop(d) is None:
        write_stop(d, "the tuner ended without a word (killed, or its computer stopped); `ksbo-mav restore` put the "
                   "baseline gains back", command, phase, EXIT["error"])
    rewrite_report(d, None, print, draw=False)
    what = "the tune is unfinished" if phase == "tune" else "the tune is done, its validation flights are incomplete"
    print(f"campaign {d.root}: {what}; `{command}` continues it")
