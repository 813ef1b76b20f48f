"""Command-line options of the simulator (shared by ``ksbo-mav sim`` and ``python -m ksbo_sim.mavlink``)."""

from __future__ import annotations

import argparse
import sys

from ksbo_sim.errors import SimInputError

DEFAULT_UDP = ("127.0.0.1", 14560)
INSTANCE_PORT_STEP = 10


def _hostport(text: str) -> tuple[str, int]:
    host, sep, port = text.rpartition(":")
    try:
        value = int(port)
        if not sep or not host or not 0 <= value <= 65535:
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected HOST:PORT, got {text!r}") from None
    return host, value


def _assignment(text: str) -> tuple[str, float]:
    name, sep, value = text.partition("=")
    try:
        if not sep or not name:
            raise ValueError
        return name.strip(), float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got {text!r}") from None


def _noise(text: str) -> tuple[float, float, float]:
    try:
        vals = [float(v) for v in text.split(",")]
        if not 1 <= len(vals) <= 3 or any(not v >= 0 for v in vals):
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected POS[,VEL[,ACC]] non-negative stds, got {text!r}") from None
    pos = vals[0]
    vel = vals[1] if len(vals) > 1 else pos
    return pos, vel, vals[2] if len(vals) > 2 else 10.0 * pos


def _numbers(n_min: int, n_max: int, sep: str = ",") -> "argparse._TypeFn":
    def parse(text: str) -> tuple[float, ...]:
        try:
            vals = tuple(float(v) for v in text.split(sep))
            if not n_min <= len(vals) <= n_max or any(not v >= 0 for v in vals):
                raise ValueError
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {n_min} to {n_max} non-negative numbers separated by "
                                             f"{sep!r}, got {text!r}") from None
        return vals
    return parse


def _drift(text: str) -> tuple[float, str]:
    rate, _, per = text.partition(",")
    try:
        value = float(rate)
        if not 0 <= value <= 1 or per not in ("", "min", "pack"):
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected RATE[,min|pack] with RATE in [0, 1], got {text!r}") from None
    return value, per or "min"


def add_condition_arguments(p: argparse.ArgumentParser) -> None:
    """A battery and a vehicle that changes while it flies (:mod:`ksbo_sim.conditions`)."""
    p.add_argument("--battery", type=_numbers(1, 3), default=None, metavar="MAH[,CELLS[,AMPS]]",
                   help="a finite pack: capacity [mAh], cells (default 3), hover current [A] (default 10); "
                        "voltage sags with discharge, SYS_STATUS/BATTERY_STATUS report it, and below BATT_LOW_VOLT "
                        "(10.5 V) for 10 s the low-battery failsafe switches to RTL (BATT_FS_LOW_ACT)")
    p.add_argument("--drift", type=_drift, default=None, metavar="RATE[,min|pack]",
                   help="the vehicle loses this fraction of its control authority per minute of flight (min) or "
                        "per full pack used (pack, needs --battery)")
    p.add_argument("--step-change", type=_numbers(2, 2, ":"), default=None, metavar="S:FACTOR",
                   help="after S seconds of flight the authority is multiplied by FACTOR (a payload, a propeller)")
    p.add_argument("--wind", type=_numbers(1, 4), default=None, metavar="MPS[,RISE[,MAX[,TURB]]]",
                   help="wind toward north: mean speed at take-off, its rise per minute of flight, its cap "
                        "(default 20), gusts as a fraction of it (default 0.3); WIND messages report it")
    p.add_argument("--drag", type=_numbers(1, 2), default=None, metavar="SCALE[,RISE]",
                   help="the airframe's drag times SCALE at take-off, rising by RISE per minute of flight (a "
                        "payload, dirt, a damaged propeller); vehicles with their own aerodynamics (copter3d)")
    p.add_argument("--wind-step", type=_numbers(2, 2, ":"), default=None, metavar="S:MPS",
                   help="after S seconds of flight the mean wind becomes MPS")


def condition_objects(args: argparse.Namespace) -> tuple | None:
    """(Battery or None, Conditions or None) from the options, or None when none is given."""
    from ksbo_sim.battery import Battery
    from ksbo_sim.conditions import Conditions

    battery = None
    if args.battery:
        b = args.battery
        if not b[0] > 0:
            raise SimInputError("--battery: the capacity must be positive")
        cells = int(b[1]) if len(b) > 1 else 3
        battery = Battery(b[0], cells=cells, hover_current_a=b[2] if len(b) > 2 else 10.0, low_volt=3.5 * cells)
    kw: dict = {"seed": args.seed}
    if args.drift:
        kw.update(drift=args.drift[0], drift_per=args.drift[1])
        if args.drift[1] == "pack" and battery is None:
            raise SimInputError("--drift RATE,pack needs --battery")
    if args.step_change:
        kw.update(step_at_s=args.step_change[0], step_factor=args.step_change[1])
    if args.wind:
        w = args.wind
        kw.update(wind_mps=w[0], wind_rise_per_min=w[1] if len(w) > 1 else 0.0,
                  wind_max_mps=w[2] if len(w) > 2 else 20.0, turbulence=w[3] if len(w) > 3 else 0.3)
    if args.wind_step:
        kw.update(wind_at_s=args.wind_step[0], wind_to_mps=args.wind_step[1])
    if args.drag:
        if not args.drag[0] > 0 or (len(args.drag) > 1 and args.drag[1] < 0):
            raise SimInputError("--drag: SCALE must be positive and RISE not negative")
        kw.update(drag_scale=args.drag[0], drag_rise_per_min=args.drag[1] if len(args.drag) > 1 else 0.0)
    conditions = Conditions(**kw) if len(kw) > 1 else None
    return (battery, conditions) if battery is not None or conditions is not None else None


def _firmware(text: str) -> int:
    """``X.Y.Z`` (an official release) or ``X.Y.Z-dev|alpha|beta|rc`` -> AUTOPILOT_VERSION.flight_sw_version."""
    kinds = {"dev": 0, "alpha": 64, "beta": 128, "rc": 192, "": 255}
    number, _, kind = text.partition("-")
    parts = number.split(".")
    if len(parts) != 3 or not all(x.isdigit() and int(x) < 256 for x in parts) or kind not in kinds:
        raise argparse.ArgumentTypeError(f"expected X.Y.Z or X.Y.Z-dev, got {text!r}")
    major, minor, patch = (int(x) for x in parts)
    return (major << 24) | (minor << 16) | (patch << 8) | kinds[kind]


def add_arguments(p: argparse.ArgumentParser) -> None:
    where = p.add_mutually_exclusive_group()
    where.add_argument("--udp", type=_hostport, metavar="HOST:PORT",
                       help="listen on UDP and answer whoever talks (default 127.0.0.1:14560; port 0 = any)")
    where.add_argument("--tcp", type=_hostport, metavar="HOST:PORT", help="TCP server (like SITL's 5760)")
    p.add_argument("--out", type=_hostport, action="append", default=[], metavar="HOST:PORT",
                   help="also send to this UDP address (for ground stations that only listen); repeatable")
    clock = p.add_mutually_exclusive_group()
    clock.add_argument("--speedup", type=float, default=1.0, metavar="X", help="real time x X (default 1)")
    clock.add_argument("--lockstep", action="store_true",
                       help="simulated time advances only with setpoints / MAV_CMD_USER_2 (for tests)")
    p.add_argument("--instance", type=int, default=0, metavar="N", help=f"add {INSTANCE_PORT_STEP}*N to the port")
    p.add_argument("--seed", type=int, default=None, help="seed of sensor noise and packet loss")
    p.add_argument("--noise", type=_noise, default=None, metavar="POS[,VEL[,ACC]]",
                   help="sensor noise stds in m, m/s, m/s^2 (default 0: exact telemetry); the telemetry reports a "
                        "Kalman estimate from the noisy sensors, and the copter3d's position loops fly it, as an "
                        "autopilot's do (so the gains turn the noise into attitude and motor activity)")
    p.add_argument("--params", default=None, metavar="FILE",
                   help="parameter file loaded at start and rewritten on every accepted PARAM_SET")
    p.add_argument("--vehicle", default="planar", help="vehicle model (default planar)")
    p.add_argument("--personality", default="ours", help="autopilot identity: ours, ardupilot, ardupilot-legacy, px4")
    p.add_argument("--sysid", type=int, default=1, help="MAVLink system id (default 1)")
    p.add_argument("--loss-in", type=float, default=None, metavar="F", help="drop this fraction of received messages")
    p.add_argument("--loss-out", type=float, default=None, metavar="F", help="drop this fraction of sent messages")
    p.add_argument("--delay-ms", type=float, default=None, metavar="MS", help="delay sent messages")
    p.add_argument("--fault-after", type=float, default=None, metavar="S",
                   help="faults start S simulated seconds into the guided setpoint stream")
    p.add_argument("--firmware", type=_firmware, default=None, metavar="X.Y.Z[-dev]",
                   help="the firmware version AUTOPILOT_VERSION reports (default: the personality's)")
    p.add_argument("--param-file", action="store_true",
                   help="serve the parameters as @PARAM/param.pck over MAVLink FTP (and say FTP in the capabilities)")
    p.add_argument("--set", type=_assignment, action="append", default=[], metavar="NAME=VALUE",
                   help="set a parameter at start (not persisted); repeatable")
    add_condition_arguments(p)


def run(args: argparse.Namespace) -> int:
    """Build the endpoint from parsed options, print the ready line, serve until SIGINT/SIGTERM."""
    from ksbo_sim.mavlink.link import Link
    from dataclasses import replace

    from ksbo_sim.mavlink.param_file import pack
    from ksbo_sim.mavlink.personality import CAP_FTP, PERSONALITIES
    from ksbo_sim.mavlink.server import Server
    from ksbo_sim.mavlink.vehicles import make_vehicle

    if args.personality not in PERSONALITIES:
        raise SimInputError(f"unknown personality {args.personality!r}; choose from {', '.join(PERSONALITIES)}")
    if not args.speedup > 0:
        raise SimInputError("--speedup must be positive")
    if args.instance < 0 or not 1 <= args.sysid <= 255:
        raise SimInputError("--instance must be >= 0 and --sysid in 1..255")
    kind = "tcp" if args.tcp else "udp"
    host, port = args.tcp or args.udp or DEFAULT_UDP
    if port:
        port += INSTANCE_PORT_STEP * args.instance
        if port > 65535:
            raise SimInputError(f"--instance {args.instance} puts the port beyond 65535")
    overrides = dict(args.set)
    for opt, name in (("loss_in", "SIM_PKT_LOSS_IN"), ("loss_out", "SIM_PKT_LOSS_OUT"),
                      ("delay_ms", "SIM_DELAY_MS"), ("fault_after", "SIM_FAULT_AFTER")):
        if getattr(args, opt) is not None:
            overrides[name] = getattr(args, opt)
    if args.noise:
        overrides.update(zip(("SIM_POS_NOISE", "SIM_VEL_NOISE", "SIM_ACC_NOISE"), args.noise))
    model, product_id = make_vehicle(args.vehicle, args.personality, args.seed)
    try:
        link = Link(kind, host, port, outs=args.out, seed=args.seed)
    except OSError as exc:
        raise SimInputError(f"cannot listen on {kind} {host}:{port}: {exc.strerror or exc}") from None
    try:
        personality = PERSONALITIES[args.personality]
        if args.firmware is not None:
            personality = replace(personality, flight_sw_version=args.firmware)
        if args.param_file:
            personality = replace(personality, extra_caps=personality.extra_caps | CAP_FTP)
        server = Server(model, personality, link, lockstep=args.lockstep, speedup=args.speedup,
                        sysid=args.sysid, seed=args.seed, params_path=args.params, product_id=product_id,
                        overrides=overrides, power=condition_objects(args))
    except BaseException:
        link.close()
        raise
    if args.param_file:
        server.ftp.readable["@PARAM/param.pck"] = lambda: pack([(s.name, server.params[s.name], s.type == "INT32")
                                                         for s in server.params.specs])
    h, p = link.address
    clock = "lockstep" if args.lockstep else f"speedup={args.speedup:g}"
    print(f"ksbo-sim ready {kind}:{h}:{p} vehicle={args.vehicle} personality={args.personality} "
          f"sysid={args.sysid} {clock}", flush=True)
    server.run()
    print("ksbo-sim stopped", file=sys.stderr, flush=True)
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m ksbo_sim.mavlink", description="MAVLink vehicle simulator")
    add_arguments(parser)
    args = parser.parse_args(argv)
    try:
        return run(args)
    except SimInputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
