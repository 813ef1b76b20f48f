"""`ksbo-mav sim`: run the built-in MAVLink vehicle simulator (see ``ksbo_sim.mavlink``), optionally behind the
link emulator (``ksbo_sim.linkemu``) as a telemetry radio would put it."""

from __future__ import annotations

import argparse
import json
import sys


def add_parser(subparsers) -> None:
    from ksbo_sim.mavlink.options import add_arguments

    p = subparsers.add_parser("sim", help="run the built-in MAVLink vehicle simulator",
                              description="Serve a simulated vehicle over MAVLink 2 like an autopilot's SITL; "
                                          "prints one ready line with its address, stops on SIGINT/SIGTERM.")
    add_arguments(p)
    p.add_argument("--link", metavar="SHAPE",
                   help="put a radio-like link between the vehicle and the ground station of --out (one): the "
                        "link emulator in its own process, e.g. down=4000,up=2000,queue=1024,loss=0.05 (bytes/s "
                        "each way, radio buffer, frame loss; also latency, jitter, burst, duplex: docs/links.md); "
                        "its counters are printed when the simulator stops")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ksbo_mav.errors import InputError
    from ksbo_sim.errors import SimError
    from ksbo_sim.mavlink.options import run as run_sim

    emulator = None
    try:
        if args.link is not None:
            emulator = _start_link(args)
        return run_sim(args)
    except SimError as exc:  # the simulator's own errors, printed as one line like every other CLI error
        raise InputError(str(exc)) from None
    finally:
        if emulator is not None:
            print(f"link: {json.dumps(emulator.stop())}", file=sys.stderr, flush=True)


def _start_link(args: argparse.Namespace):
    """Start the emulator between the simulator and the one --out address; the simulator then sends to it."""
    from ksbo_mav.errors import InputError
    from ksbo_sim.linkproc import LinkEmulator
    from ksbo_sim.linkshape import LinkShape

    LinkShape.parse(args.link)  # a bad shape is one line before anything starts
    if len(args.out) != 1:
        raise InputError("--link needs exactly one --out HOST:PORT: the ground station the link leads to (e.g. "
                         "--out 127.0.0.1:14550 and `ksbo-mav tune --udp 127.0.0.1:14550`)")
    host, port = args.out[0]
    emulator = LinkEmulator("udpin:127.0.0.1:0", f"udp:{host}:{port}", args.link)
    args.out = [("127.0.0.1", emulator.vehicle_port)]
    print(emulator.ready_line, flush=True)
    return emulator
