"""A bench pilot for a SITL without a transmitter: the sticks centred while the vehicle flies, the throttle low on
the ground, as a pilot holds them who lets the autopilot fly.

Why a bench needs one: ArduCopter's LOITER (the pilot's take-over mode, the onboard guard's stop, the validation's
hold) flies the sticks, and ArduCopter SITL's simulated transmitter rests with the throttle low (1000 us), so a
LOITER on the bench descends and lands; a centred throttle on the ground, in turn, is no pilot's habit. PX4 reads
MAVLink MANUAL_CONTROL as its sticks.

What it sends, ten times a second:

* ArduPilot SITL: its RC input (UDP ``5501 + 10 N`` for instance ``N``; the SITL keeps the last values it got):
  16 little-endian uint16 pulse widths, roll / pitch / yaw at 1500 us, the throttle 1500 us airborne and 1000 us on
  the ground, channels 5-16 as 0 (left as they are: the flight-mode switch is not touched). The tuner sets
  ``MAV_GCS_SYSID`` to itself for its onboard guard, so RC_CHANNELS_OVERRIDE from another system would be ignored;
  the SITL's RC input is its transmitter, whoever the ground station is.
* PX4: MANUAL_CONTROL on the pilot's own MAVLink connection, x / y / r 0 and z 500 (centred) airborne, 0 on the
  ground.

"Airborne" is read on the pilot's own MAVLink connection (a port the tuner does not use): armed and at least
``airborne_m`` above home (GLOBAL_POSITION_INT.relative_alt), until below half that or disarmed.

    python -m ksbo_sim.bench_pilot --device tcp:127.0.0.1:5763            # ArduCopter SITL instance 0
    python -m ksbo_sim.bench_pilot --device udpin:127.0.0.1:14550          # PX4 SITL's GCS link

(``ksbo-mav sim-pilot`` is the same.) It prints one line when it starts and one at each change of the sticks, and
runs until SIGINT/SIGTERM. Standard library and pymavlink only: ksbo_sim never imports ksbo_mav.
"""

from __future__ import annotations

import argparse
import os
import select
import signal
import socket
import struct
import subprocess
import sys
import time

#: Pulse widths (us): centred stick, throttle low.
CENTRE, LOW = 1500, 1000
#: ArduCopter SITL's first TCP port and its RC input port, instance 0 (each instance adds 10 to both).
SITL_TCP0, SITL_RC0 = 5760, 5501
SEND_HZ = 10.0
#: GLOBAL_POSITION_INT asked for on the pilot's link (SET_MESSAGE_INTERVAL: nothing stored on the vehicle).
POSITION_HZ = 4.0


def rc_port_for(device: str) -> int | None:
    """ArduCopter SITL's RC input port for a device on one of its TCP ports (5760..5763 + 10 N), else None."""
    kind, _, rest = device.partition(":")
    port = rest.rpartition(":")[2]
    n = (int(port) - SITL_TCP0) // 10 if port.isdigit() else -1
    if kind != "tcp" or not 0 <= n < 100 or (int(port) - SITL_TCP0) % 10 > 3:
        return None
    return SITL_RC0 + 10 * n


class BenchPilot:
    """Holds the sticks of the vehicle on ``device`` (pymavlink notation); ``rc_port``: ArduPilot SITL's RC input
    (default from the device's TCP port, :func:`rc_port_for`); ``airborne_m``: height that counts as flying."""

    def __init__(self, device: str, rc_port: int | None = None, airborne_m: float = 1.0, sysid: int = 252,
                 say=print, connect_timeout: float = 120.0) -> None:
        os.environ.setdefault("MAVLINK20", "1")
        from pymavlink import mavutil

        self.device, self.airborne_m, self.say = device, float(airborne_m), say
        self.rc_port = rc_port if rc_port is not None else rc_port_for(device)
        deadline = time.monotonic() + connect_timeout
        while True:  # a SITL opens its further TCP ports once its first client has connected
            try:
                self.conn = mavutil.mavlink_connection(device, source_system=sysid, source_component=190,
                                                       autoreconnect=True)
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(1.0)
        self.rc = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.autopilot: int | None = None  # HEARTBEAT.autopilot: 3 ArduPilot, 12 PX4
        self.target = 1
        self.armed = False
        self.height: float | None = None
        self.flying = False
        self.stop = False
        self._asked = 0.0

    def _take(self, m) -> None:
        kind = m.get_type()
        if kind == "HEARTBEAT" and m.get_srcComponent() == 1 and m.type not in (6, 27):  # not a GCS / radio
            self.autopilot, self.target = int(m.autopilot), m.get_srcSystem()
            self.armed = bool(m.base_mode & 128)
        elif kind == "GLOBAL_POSITION_INT" and m.get_srcSystem() == self.target:
            self.height = m.relative_alt / 1000.0

    def _ask_position(self, now: float) -> None:
        """GLOBAL_POSITION_INT at :data:`POSITION_HZ` on this link, asked again every 5 s (a rebooted vehicle)."""
        if self.autopilot is None or now - self._asked < 5.0:
            return
        self._asked = now
        self.conn.mav.command_long_send(self.target, 1, 511, 0, 33, 1e6 / POSITION_HZ, 0, 0, 0, 0, 0)

    def _update(self) -> None:
        was = self.flying
        if not self.armed or self.height is None:
            self.flying = False
        elif self.height >= self.airborne_m:
            self.flying = True
        elif self.height < 0.5 * self.airborne_m:
            self.flying = False
        if self.flying != was:
            h = "?" if self.height is None else f"{self.height:.1f}"
            self.say(f"bench pilot: {'airborne' if self.flying else 'on the ground or disarmed'} ({h} m up, "
                     f"{'armed' if self.armed else 'disarmed'}): "
                     + ("sticks centred, throttle 1500 us" if self.flying else "throttle low, 1000 us"))

    def _send(self) -> None:
        if self.autopilot == 12:  # PX4: MANUAL_CONTROL, z 0..1000 (500 centred)
            self.conn.mav.manual_control_send(self.target, 0, 0, 500 if self.flying else 0, 0, 0)
        elif self.rc_port is not None:
            values = [CENTRE, CENTRE, CENTRE if self.flying else LOW, CENTRE] + [0] * 12
            try:
                self.rc.sendto(struct.pack("<16H", *values), ("127.0.0.1", self.rc_port))
            except OSError:
                pass  # the SITL not up (yet): it takes the next one

    def run(self) -> None:
        where = f"RC input UDP 127.0.0.1:{self.rc_port}" if self.rc_port is not None else "MANUAL_CONTROL (PX4)"
        self.say(f"bench pilot ready: watching {self.device}, sticks to {where}; throttle low until the vehicle is "
                 f"armed and {self.airborne_m:g} m up", )
        next_send = 0.0
        while not self.stop:
            m = self.conn.recv_match(blocking=True, timeout=0.05)
            while m is not None:
                self._take(m)
                m = self.conn.recv_match(blocking=False)
            now = time.monotonic()
            self._ask_position(now)
            self._update()
            if now >= next_send:
                next_send = now + 1.0 / SEND_HZ
                self._send()

    def close(self) -> None:
        self.conn.close()
        self.rc.close()


class PilotProcess:
    """``python -m ksbo_sim.bench_pilot`` as a child process (tests, benchmarks), ready when the constructor
    returns; :meth:`stop` ends it by its PID and returns what it printed."""

    def __init__(self, device: str, *args: str, startup_timeout: float = 20.0) -> None:
        env = dict(os.environ, MAVLINK20="1")
        self.proc = subprocess.Popen([sys.executable, "-m", "ksbo_sim.bench_pilot", "--device", device, *args],
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
        ready, _, _ = select.select([self.proc.stdout], [], [], startup_timeout)
        line = self.proc.stdout.readline() if ready else ""
        if not line.startswith("bench pilot ready"):
            self.proc.kill()
            raise RuntimeError(f"the bench pilot did not start: {line.strip() or self.proc.stdout.read()[-500:]}")
        self.ready_line = line.strip()

    def stop(self) -> str:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        try:
            out, _ = self.proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            out, _ = self.proc.communicate()
        return out

    def __enter__(self) -> "PilotProcess":
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--device", help="the pilot's own MAVLink connection, pymavlink notation: tcp:127.0.0.1:5763 "
                    "(ArduCopter SITL's third port), udpin:127.0.0.1:14550 (PX4 SITL's GCS link)")
    ap.add_argument("--rc-port", type=int, metavar="PORT", help="ArduPilot SITL's RC input port (default: 5501 + "
                    "10 N from a TCP device on instance N's ports 5760..5763 + 10 N)")
    ap.add_argument("--airborne", type=float, default=1.0, metavar="M", help="height above home from which the "
                    "sticks are centred, while armed (default: %(default)g m)")


def run(args: argparse.Namespace, say=print) -> int:
    """Fly the bench pilot until SIGINT/SIGTERM; 2 (one line) for a device it cannot use."""
    if not args.device:
        print("error: give --device (e.g. tcp:127.0.0.1:5763 for ArduCopter SITL instance 0)", file=sys.stderr)
        return 2
    try:
        pilot = BenchPilot(args.device, args.rc_port, args.airborne,
                           say=lambda s: (say(s), sys.stdout.flush()))
    except (OSError, ValueError) as exc:
        print(f"error: {args.device}: {exc}", file=sys.stderr)
        return 2

    def stop(*_: object) -> None:
        pilot.stop = True

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    try:
        pilot.run()
    finally:
        pilot.close()
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m ksbo_sim.bench_pilot", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(ap)
    return run(ap.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
