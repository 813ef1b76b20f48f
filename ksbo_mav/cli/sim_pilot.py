"""`ksbo-mav sim-pilot`: a bench pilot for a SITL without a transmitter (``ksbo_sim.bench_pilot``): the sticks
centred while the vehicle flies, the throttle low on the ground."""

from __future__ import annotations

import argparse


def add_parser(subparsers) -> None:
    from ksbo_sim.bench_pilot import add_arguments

    p = subparsers.add_parser(
        "sim-pilot", help="hold a SITL's sticks as a pilot does: centred airborne, throttle low on the ground",
        description="A bench without a transmitter cannot centre its sticks: ArduCopter SITL's simulated "
                    "transmitter rests with the throttle low, so LOITER (a pilot's take-over, the onboard guard's "
                    "stop, the validation's hold) descends. This feeds the SITL's RC input (ArduPilot: its UDP RC "
                    "port 5501 + 10 N; PX4: MANUAL_CONTROL) ten times a second: roll, pitch, yaw and throttle "
                    "centred while the vehicle is armed and airborne, the throttle low otherwise. It watches the "
                    "vehicle on its own MAVLink connection (not the tuner's) and runs until Ctrl-C. Example, "
                    "ArduCopter SITL instance 0: ksbo-mav sim-pilot --device tcp:127.0.0.1:5763 (docs/sitl.md).")
    add_arguments(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ksbo_sim.bench_pilot import run as run_pilot

    return run_pilot(args)
