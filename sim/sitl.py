"""Real autopilot SITLs as child processes: ArduCopter SITL and PX4 SITL (SIH), for tests and benchmarks.

Finds the ``run`` scripts (``$KSBO_ARDUPILOT_SITL`` / ``$KSBO_PX4_SITL`` — a ``run`` script, or a folder holding
one — else ``shared/sitl/{ardupilot,px4}/run`` beside or above the checkout), starts one instance on its own
instance number (so ports never collide), waits for its first HEARTBEAT on loopback, and stops it by PID.

Endpoints as the tuner sees them (``ksbo-mav tune --tcp/--udp ...``):

* ArduCopter instance N: TCP server ``127.0.0.1:5760+10N`` (SERIAL0; its clock starts when a client connects),
  further TCP ports 5762+10N and 5763+10N.
* PX4 instance N: PX4 sends to ``127.0.0.1:14540+N`` (API link) and ``14550+N`` (GCS link); a client listens
  (``--udp 127.0.0.1:14540+N``). Both run at PX4's SITL rate of 4 MB/s; its third instance (sends to
  ``14030+N``, listens on ``14280+N``) is rated 4000 B/s, so PX4 scales its streams to a telemetry radio's budget
  there, as it does on a radio port set by ``MAV_x_RATE``.

This module uses only the standard library and pymavlink: ksbo_sim never imports ksbo_mav.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

ENV = {"ardupilot": "KSBO_ARDUPILOT_SITL", "px4": "KSBO_PX4_SITL"}


class SitlNotFound(RuntimeError):
    """No SITL of that kind on this machine (the message says where we looked)."""


def find_run_script(kind: str) -> Path:
    """Path of the ``run`` script for ``kind`` ("ardupilot" or "px4"); :class:`SitlNotFound` with the places
    searched otherwise."""
    if kind not in ENV:
        raise ValueError(f"unknown SITL kind {kind!r}; known: {', '.join(ENV)}")
    tried: list[str] = []
    env = os.environ.get(ENV[kind])
    candidates: list[Path] = []
    if env:
        p = Path(env)
        candidates.append(p / "run" if p.is_dir() else p)
    here = Path(__file__).resolve()
    for parent in list(here.parents)[:5] + list(Path.cwd().resolve().parents)[:3] + [Path.cwd().resolve()]:
        candidates.append(parent / "shared" / "sitl" / kind / "run")
    for c in candidates:
        tried.append(str(c))
        if c.is_file() and os.access(c, os.X_OK):
            return c
    raise SitlNotFound(f"no {kind} SITL found (set {ENV[kind]} to its run script; looked at "
                       + ", ".join(dict.fromkeys(tried)) + ")")


@dataclass
class Sitl:
    """One running SITL instance. Use as a context manager or call :meth:`stop`."""

    kind: str
    instance: int
    speedup: float
    workdir: Path
    proc: subprocess.Popen
    log_path: Path
    _own_workdir: bool = field(default=False, repr=False)

    # --- endpoints -------------------------------------------------------------------------------------------
    @property
    def tcp_port(self) -> int:
        """ArduCopter SERIAL0 (the client port)."""
        return 5760 + 10 * self.instance

    @property
    def tcp_ports(self) -> tuple[int, int, int]:
        """ArduCopter's three TCP server ports: SERIAL0, and 5762/5763 + 10N."""
        return 5760 + 10 * self.instance, 5762 + 10 * self.instance, 5763 + 10 * self.instance

    @property
    def udp_port(self) -> int:
        """PX4: where the API link sends (a client listens here)."""
        return 14540 + self.instance

    @property
    def radio_udp_port(self) -> int:
        """PX4: where its 4000 B/s link sends (streams scaled to a radio's budget; a client listens here)."""
        return 14030 + self.instance

    @property
    def gcs_udp_port(self) -> int:
        """PX4: where the GCS link sends."""
        return 14550 + self.instance

    @property
    def device(self) -> str:
        """pymavlink device string of the primary client endpoint."""
        if self.kind == "ardupilot":
            return f"tcp:127.0.0.1:{self.tcp_port}"
        return f"udpin:127.0.0.1:{self.udp_port}"

    @property
    def cli_args(self) -> list[str]:
        """The tuner's connection option for this instance (``--tcp HOST:PORT`` / ``--udp HOST:PORT``)."""
        if self.kind == "ardupilot":
            return ["--tcp", f"127.0.0.1:{self.tcp_port}"]
        return ["--udp", f"127.0.0.1:{self.udp_port}"]

    @property
    def sysid(self) -> int:
        return 1 if self.kind == "ardupilot" else 1 + self.instance

    # --- lifecycle -------------------------------------------------------------------------------------------
    @property
    def alive(self) -> bool:
        return self.proc.poll() is None

    def output(self) -> str:
        try:
            return self.log_path.read_text(errors="replace")
        except OSError:
            return ""

    def logs(self, suffix: str) -> list[Path]:
        """Flight logs the autopilot wrote: ``.BIN`` (ArduCopter) or ``.ulg`` (PX4), oldest first."""
        base = self.workdir / ("logs" if self.kind == "ardupilot" else "rootfs/log")
        return sorted(base.rglob(f"*{suffix}"), key=lambda p: p.stat().st_mtime) if base.exists() else []

    def stop(self, timeout: float = 10.0) -> int | None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)
        if self._own_workdir:
            shutil.rmtree(self.workdir, ignore_errors=True)
        return self.proc.returncode

    def set_param(self, name: str, value: float, int32: bool = False, timeout: float = 10.0,
                  second_port: bool = False) -> float:
        """Set one parameter over a separate connection (test set-up, e.g. PX4's COM_RCL_EXCEPT for a vehicle
        with no RC); returns the echoed value. PX4 INT32 values travel byte-wise in the float field.
        ``second_port``: ArduCopter's second TCP port, while a client holds the first (the wind raised
        mid-campaign)."""
        os.environ.setdefault("MAVLINK20", "1")
        import struct

        from pymavlink import mavutil

        device = f"tcp:127.0.0.1:{self.tcp_ports[1]}" if second_port and self.kind == "ardupilot" else self.device
        conn = mavutil.mavlink_connection(device, source_system=253, source_component=190, autoreconnect=False)
        try:
            hb = conn.wait_heartbeat(timeout=timeout)
            if hb is None:
                raise RuntimeError(f"{self.kind} SITL: no heartbeat to set {name}")
            bytewise = self.kind == "px4" and int32
            wire = struct.unpack("<f", struct.pack("<i", int(value)))[0] if bytewise else float(value)
            ptype = mavutil.mavlink.MAV_PARAM_TYPE_INT32 if int32 else mavutil.mavlink.MAV_PARAM_TYPE_REAL32
            deadline = time.monotonic() + timeout
            while time.monotonic() < deadline:
                conn.mav.param_set_send(conn.target_system, conn.target_component, name.encode(), wire, ptype)
                msg = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=1.0)
                while msg is not None and msg.param_id != name:
                    msg = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=1.0)
                if msg is not None:
                    got = msg.param_value
                    if bytewise:
                        got = struct.unpack("<i", struct.pack("<f", got))[0]
                    if abs(got - value) < 1e-6:
                        return float(got)
            raise RuntimeError(f"{self.kind} SITL did not confirm {name} = {value}")
        finally:
            conn.close()

    def kill(self) -> None:
        """SIGKILL (the process dies at once: a power cut)."""
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(5)

    def __enter__(self) -> "Sitl":
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


#: Simulated packs that last, set by :func:`start_sitl` (unless ``keep_params``). PX4 SITL's pack drains to
#: SIM_BAT_MIN_PCT (50 %) in SIM_BAT_DRAIN (60) s and then holds: a third of it in the first trial. ArduCopter
#: SITL's 3.3 Ah pack lasts about ten figure-8 trials, fewer than one test module flies on its shared SITL. A tuner
#: that watches the battery rightly stops on either; tests that want a finite pack set their own.
LASTING_PACK = {"px4": {"SIM_BAT_DRAIN": 1800.0},
                "ardupilot": {"SIM_BATT_CAP_AH": 33.0, "BATT_CAPACITY": 33000.0}}


def ports_taken(kind: str, n: int) -> list[str]:
    """The ports instance ``n`` of ``kind`` binds (and its client listens on) that something holds right now.

    TCP ports are probed with SO_REUSEADDR, as the autopilot binds them: a port whose last connections linger in
    TIME_WAIT is free, one with a listener is not. UDP ports without it: any holder counts (pymavlink's ``udpin``
    sets SO_REUSEADDR and would share the port unseen)."""
    tcp = [5760 + 10 * n, 5762 + 10 * n, 5763 + 10 * n] if kind == "ardupilot" else []
    udp = [5501 + 10 * n] if kind == "ardupilot" else [14540 + n, 14580 + n, 18570 + n]
    taken = []
    for family, ports in ((socket.SOCK_STREAM, tcp), (socket.SOCK_DGRAM, udp)):
        for port in ports:
            with socket.socket(socket.AF_INET, family) as s:
                if family == socket.SOCK_STREAM:
                    s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                try:
                    s.bind(("127.0.0.1", port))
                except OSError:
                    taken.append(f"{'TCP' if family == socket.SOCK_STREAM else 'UDP'} {port}")
    return taken


def start_sitl(kind: str, instance: int = 0, speedup: float = 1.0, workdir: str | Path | None = None,
               keep_params: bool = False, heartbeat_timeout: float = 60.0, scripting: bool = True) -> Sitl:
    """Start a SITL and wait until it sends a HEARTBEAT on loopback.

    ``scripting`` (ArduCopter, default on): boot with Lua scripting on (``SCR_ENABLE`` 1 from a second defaults
    file after ``copter.parm``; the setting takes effect only at boot), as a vehicle prepared for the tuner's
    onboard guard, which ``ksbo-mav tune`` requires unless ``--no-onboard-guard``.

    ArduCopter's clock only starts once a client connects to SERIAL0; the heartbeat probe connects and
    disconnects (ArduPilot accepts the next client on the same port). :class:`SitlNotFound` if no SITL is
    installed, RuntimeError (with the process output) if it does not come up, ValueError for a PX4 instance
    outside 0..9.
    """
    if kind == "px4" and not 0 <= instance <= 9:
        # PX4's startup script sends every instance from 10 up to one API port (14549), not 14540+N.
        raise ValueError(f"PX4 SITL instance {instance}: use 0..9 (instances from 10 up share one API port)")
    script = find_run_script(kind)
    taken = ports_taken(kind, instance)
    if taken:  # a second autopilot on them would die at once, and its start would find the first one's heartbeat
        raise RuntimeError(f"{kind} SITL instance {instance}: {', '.join(taken)} already in use (another SITL or "
                           "its client?); take another instance number (ksbo_sim.sitl_instances.start_claimed "
                           "finds a free one)")
    own = workdir is None
    wd = Path(tempfile.mkdtemp(prefix=f"ksbo-{kind}-sitl-")) if own else Path(workdir)
    wd.mkdir(parents=True, exist_ok=True)
    log_path = wd / "sitl-output.txt"
    if kind == "ardupilot":
        args = [str(script), "-I", str(instance), "-s", f"{speedup:g}", "-d", str(wd)] + (["-k"] if keep_params else [])
        if scripting:  # ArduPilot reads a comma-separated defaults list; a later --defaults replaces the run script's
            extra = wd / "scripting.parm"
            extra.write_text("SCR_ENABLE 1\n")
            args += ["--", "--defaults", f"{script.parent / 'copter.parm'},{extra}"]
    else:
        args = [str(script), "-i", str(instance), "-s", f"{speedup:g}", "-w", str(wd)] + (["-k"] if keep_params else [])
    with open(log_path, "wb") as out:
        # Own process group: a test runner's Ctrl-C is for the runner, the fixture stops the SITL by PID.
        proc = subprocess.Popen(args, stdout=out, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                start_new_session=True)
    sitl = Sitl(kind, instance, speedup, wd, proc, log_path, own)
    try:
        _wait_heartbeat(sitl, heartbeat_timeout)
        for name, value in ({} if keep_params else LASTING_PACK[kind]).items():
            sitl.set_param(name, value)
        if not sitl.alive:  # the heartbeats came from someone else's autopilot on these ports
            raise RuntimeError(f"{kind} SITL exited with {sitl.proc.returncode}: {sitl.output()[-2000:]}")
    except BaseException:
        sitl.stop()
        raise
    return sitl


def _wait_heartbeat(sitl: Sitl, timeout: float) -> None:
    os.environ.setdefault("MAVLINK20", "1")
    from pymavlink import mavutil

    deadline = time.monotonic() + timeout
    last_err = ""
    while time.monotonic() < deadline:
        if not sitl.alive:
            raise RuntimeError(f"{sitl.kind} SITL exited with {sitl.proc.returncode}: {sitl.output()[-2000:]}")
        try:
            conn = mavutil.mavlink_connection(sitl.device, source_system=254, source_component=190,
                                              autoreconnect=False)
        except OSError as exc:  # TCP port not open yet
            last_err = str(exc)
            time.sleep(0.3)
            continue
        try:
            end = min(deadline, time.monotonic() + 5.0)
            while time.monotonic() < end:
                msg = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=0.5)
                if msg is not None and msg.autopilot != 8 and msg.type != 6:
                    return
        except OSError as exc:
            last_err = str(exc)
        finally:
            conn.close()
    raise RuntimeError(f"{sitl.kind} SITL sent no HEARTBEAT within {timeout:g} s ({last_err}); "
                       f"output: {sitl.output()[-2000:]}")
