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
    from ksbo_mav.errors import InputError
    from ksbo_sim.errors import SimError
    from ksbo_sim.mavlink.options import run as run_sim

    try:
        return run_sim(args)
    except SimError as exc:  # the simulator's own errors, printed as one line like every other CLI error
        raise InputError(str(exc)) from None
