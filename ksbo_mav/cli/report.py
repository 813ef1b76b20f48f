"""`ksbo-mav report DIR`: regenerate a campaign's report (plots and report/index.html) from its directory."""

from __future__ import annotations

import argparse


def add_parser(subparsers) -> None:
    p = subparsers.add_parser("report", help="regenerate a campaign's report page and plots from its directory",
                              description="Reads the campaign directory alone (settings, journal, trial tlogs, "
                                          "result.json), no vehicle needed: writes DIR/report/*.png and "
                                          "DIR/report/index.html, one self-contained page (verdict, where the "
                                          "recommendation touches the search box, plots, every flown trial). "
                                          "Works on an unfinished campaign too (trials so far).")
    p.add_argument("dir", metavar="DIR", help="campaign directory")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ksbo_mav.campaign.layout import CampaignDir
    from ksbo_mav.campaign.report.writer import box_edge_lines, write_report
    from ksbo_mav.errors import InputError

    d = CampaignDir.at(args.dir)
    if not d.config.exists():
        raise InputError(f"{args.dir} holds no campaign (no campaign.json)")
    paths = write_report(d, fresh=True)
    for line in box_edge_lines(d):
        print(f"search box: {line}")
    for name, path in paths.items():
        if name != "page" and path != "none":
            print(f"plot ({name}): {path}")
    print(f"report: {paths['page']}")
    return 0
