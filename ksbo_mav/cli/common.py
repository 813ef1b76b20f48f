"""Argument helpers shared by the command modules."""

from __future__ import annotations

import argparse
import math
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.jsonio import dumps
from ksbo_mav.profiles import Profile


def writable_output(path: str | None, option: str = "--plot") -> None:
    """InputError (one line) unless a file can be written at ``path`` (its directory is created if missing): checked
    before any work, so a bad path never costs a scoring run or ends in a traceback."""
    if path is None:
        return
    from pathlib import Path

    p = Path(path)
    if p.is_dir():
        raise InputError(f"{option} {path}: is a directory; give a file name such as {p / 'plot.png'}")
    import os

    try:
        p.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"{option} {path}: cannot create its directory ({exc.strerror or exc})") from None
    if not os.access(p.parent, os.W_OK) or (p.exists() and not os.access(p, os.W_OK)):
        raise InputError(f"{option} {path}: not writable")


def parse_gains(text: str, profile: Profile) -> np.ndarray:
    """A preset name (``default``, ``scg``) or ``d`` comma-separated numbers in the profile's order."""
    text = text.strip()
    if text and not any(ch.isdigit() for ch in text) and "," not in text and text.lower() not in {"nan", "inf"}:
        return profile.preset(text)
    parts = [p for p in text.replace(" ", "").split(",")]
    if len(parts) != profile.dim:
        raise InputError(f"--gains needs {profile.dim} comma-separated values ({', '.join(profile.labels)}) "
                         f"or a preset name, got {len(parts)} value(s)")
    try:
        values = np.array([float(p) for p in parts])
    except ValueError:
        raise InputError(f"--gains: {text!r} contains a value that is not a number") from None
    return values


def planar_profile(name: str, command: str) -> Profile:
    """Load a profile the in-process planar simulator can fly (``evaluate``, ``prior``), or refuse it in one line."""
    from ksbo_mav.profiles import load_profile

    profile = load_profile(name)
    if profile.frame != "planar-xz":
        raise InputError(f"`ksbo-mav {command}` flies the built-in planar simulator; profile {profile.name!r} is "
                         f"for a {profile.frame} vehicle (tune it over MAVLink: `ksbo-mav sim --vehicle copter3d` "
                         f"and `ksbo-mav tune`)")
    return profile


def positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError("must be at least 1")
    return value


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError("must be a positive number")
    return value


def to_json(obj: Any) -> str:
    """JSON with NaN/inf written as null and numpy scalars/arrays converted."""
    return dumps(obj, indent=2)


def add_connection_args(p: argparse.ArgumentParser) -> Any:
    """Vehicle connection options shared by tune / restore / accept; returns their group."""
    g = p.add_argument_group("connection (exactly one)")
    g.add_argument("--udp", metavar="HOST:PORT", help="listen for the vehicle on UDP, as a ground station does")
    g.add_argument("--udp-out", metavar="HOST:PORT", help="send to a vehicle that listens on UDP (we talk first)")
    g.add_argument("--tcp", metavar="HOST:PORT", help="connect to a TCP server (SITL 5760, a telemetry bridge)")
    g.add_argument("--serial", metavar="DEV[:BAUD]", help="serial port, e.g. /dev/ttyUSB0:57600")
    g.add_argument("--sysid", type=int, default=None, help="our MAVLink system id (default 245)")
    g.add_argument("--compid", type=int, default=None, help="our MAVLink component id (default 191)")
    g.add_argument("--timeout", type=positive_float, default=15.0, metavar="S",
                   help="seconds to wait for the vehicle's first heartbeat (default: %(default)g)")
    g.add_argument("--signing-key", metavar="FILE", help="a vehicle that signs its link (MAVLink 2 signing): its "
                   "key, 32 raw bytes or a passphrase line (default: the file $KSBO_SIGNING_KEY_FILE names)")
    return g


def endpoint_from_args(args: argparse.Namespace):
    from dataclasses import replace

    from ksbo_mav.mav.link import parse_endpoint
    from ksbo_mav.mav.signing import key_from

    endpoint = parse_endpoint(udp=args.udp, udpout=args.udp_out, tcp=args.tcp, serial=args.serial)
    return replace(endpoint, signing=key_from(getattr(args, "signing_key", None)))
