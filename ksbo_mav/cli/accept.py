"""`ksbo-mav accept DIR`: write a finished campaign's best gains to the vehicle (verified) and export them."""

from __future__ import annotations

import argparse

from ksbo_mav.cli.common import add_connection_args, endpoint_from_args


def add_parser(subparsers) -> None:
    p = subparsers.add_parser("accept", help="write a finished campaign's best gains (verified), export .param",
                              description="Writes DIR/result.json's best gains, checked against the snapshot's "
                                          "baseline trust region, verifies them, and writes DIR/accepted.param, "
                                          "DIR/accepted.params and DIR/diff.txt. Gains that failed a confirmation "
                                          "flight (aborted, crashed or P < 0) are refused unless --force.")
    p.add_argument("dir", metavar="DIR")
    p.add_argument("--force", action="store_true",
                   help="write the best gains even if a confirmation flight of them failed")
    add_connection_args(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ksbo_mav.campaign import CampaignDir, accept_campaign

    best = accept_campaign(args.dir, endpoint_from_args(args), log=lambda s: print(s), timeout=args.timeout,
                            sysid=args.sysid, compid=args.compid, force=args.force)
    d = CampaignDir.at(args.dir)
    print(d.diff.read_text(), end="")
    print(f"accepted {len(best)} gain(s); exported {d.accepted_stem.with_suffix('.param')} and .params")
    return 0
