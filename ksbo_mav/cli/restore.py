"""`ksbo-mav restore SNAPSHOT`: put the snapshot's gains back on the vehicle and verify them by a fresh read."""

from __future__ import annotations

import argparse

from ksbo_mav.cli.common import add_connection_args, endpoint_from_args


def add_parser(subparsers) -> None:
    p = subparsers.add_parser("restore", help="write a snapshot's gains back to the vehicle (verified)",
                              description="Works from disk alone, also after the tuner crashed: SNAPSHOT is a "
                                          "campaign directory or its snapshot/vehicle.json.")
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
    return 0
