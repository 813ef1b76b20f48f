"""`ksbo-mav validate DIR`: fly a finished campaign's validation flights (baseline against the recommendation on
the profile's manoeuvres), later or again, and print the verdict per manoeuvre."""

from __future__ import annotations

import argparse

from ksbo_mav.cli.common import add_connection_args, endpoint_from_args


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "validate", help="fly a campaign's validation flights (steps, hold, AUTO mission): baseline vs recommendation",
        description="Flies the baseline and the recommended gains of the finished campaign in DIR alternately "
                    "(A B A B ...) on the manoeuvres of its profile's [validation] section - position steps, a "
                    "position hold, an AUTO waypoint mission - each flight monitored, journalled in "
                    "DIR/validation.jsonl (never given to the optimiser) and restored like a trial; flights the "
                    "journal already holds are not flown again. The gains found on the vehicle (the baseline, or "
                    "the accepted recommendation) are put back after every flight and at the end. Prints, per "
                    "manoeuvre, better / no measurable change / worse (beyond the repeats' spread) and rewrites "
                    "DIR/report/index.html. Exit status: 0 validated; 4 incomplete (a manoeuvre that could not be "
                    "flown, the pack; the console says why, and running it again flies the rest); 2 an error; 130 "
                    "Ctrl-C.")
    p.add_argument("dir", metavar="DIR", help="a finished campaign's directory")
    p.add_argument("--validation", choices=("quick", "full"), default=None,
                   help="quick: the profile's repeats; full: its full_repeats and more candidates (default: the "
                        "campaign's setting, quick if it was off)")
    p.add_argument("--end", choices=("land", "hold"), default="land", help="after the flights: land and disarm, or "
                   "hold position (default: %(default)s)")
    add_connection_args(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ksbo_mav.campaign.validation_session import validate_campaign

    rep = validate_campaign(args.dir, endpoint_from_args(args), mode=args.validation, end=args.end,
                            log=lambda s: print(s), timeout=args.timeout, sysid=args.sysid, compid=args.compid)
    from ksbo_mav.campaign.stops import EXIT

    return EXIT["unvalidated"] if rep.incomplete() else EXIT["ok"]
