"""`ksbo-mav sim`: run the built-in MAVLink vehicle simulator (see ``ksbo_sim.mavlink``)."""

from __future__ import annotations

import argparse


def add_parser(subparsers) -> None:
    from ksbo_sim.mavlink.options import add_arguments

    p = subparsers.add_parser("sim", help="run the built-in MAVLink vehicle simulator",
                              description="Serve a simulated vehicle over MAVLink 2 like an autopilot's SITL; "
                                          "prints one ready line with its address, stops on SIGINT/SIGTERM.")
    add_arguments(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ksbo_sim.mavlink.options import run as run_sim

    return run_sim(args)
