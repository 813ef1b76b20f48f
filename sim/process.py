"""The MAVLink vehicle simulator in its own process: ``python -m ksbo_sim.mavlink ...``, started and stopped.

Used by ``ksbo-mav demo``, the tests and the benchmarks. The child prints one ready line
(``ksbo-sim ready udp:127.0.0.1:PORT ...``) once it listens; :class:`SimProcess` waits for it and keeps the
address. Standard library only (``ksbo_sim`` never imports ``ksbo_mav``).
"""

from __future__ import annotations

import collections
import select
import random
import signal
import socket
import subprocess
import sys
import threading

from ksbo_sim.errors import SimStartError


def free_udp_port() -> int:
    """A UDP port on 127.0.0.1 that is free right now (for the side that listens, e.g. the tuner).

    Drawn below Linux's ephemeral range (32768-60999): a port the kernel picked for bind(0) is handed out again to
    the next process that binds one (the simulator's own socket, a ground station's), which then holds the port
    the tuner was about to listen on."""
    rng = random.Random()
    for _ in range(200):
        port = rng.randrange(20000, 32768)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            try:
                s.bind(("127.0.0.1", port))
            except OSError:
                continue
            return port
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


#: Lines of the child's stdout and stderr :meth:`SimProcess.output` keeps.
TAIL_LINES = 1000


def _drain(pipe, tail: collections.deque) -> None:
    for line in iter(pipe.readline, ""):
        tail.append(line)


class SimProcess:
    """``python -m ksbo_sim.mavlink *args`` in a child process, ready when the constructor returns.

    Without ``--udp``/``--tcp`` in ``args`` it listens on ``kind`` 127.0.0.1 on a free port; ``out_port`` adds
    ``--out 127.0.0.1:out_port`` (the simulator also sends there, where a ground station or the tuner listens).
    ``kind``, ``host`` and ``port`` are the simulator's own address, from its ready line.
    """

    def __init__(self, *args: str, kind: str = "udp", out_port: int | None = None,
                 startup_timeout: float = 60.0) -> None:
        where = [] if "--udp" in args or "--tcp" in args else [f"--{kind}", "127.0.0.1:0"]  # port 0: any free
        out = [] if out_port is None else ["--out", f"127.0.0.1:{out_port}"]
        cmd = [sys.executable, "-m", "ksbo_sim.mavlink", *where, *out, *args]
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        ready, _, _ = select.select([self.proc.stdout], [], [], startup_timeout)
        line = self.proc.stdout.readline() if ready else ""
        if not line.startswith("ksbo-sim ready"):
            self.stop(signal.SIGKILL)
            err = (self.proc.stderr.read() or "").strip().splitlines()
            why = line.strip() or (err[-1] if err else f"no ready line within {startup_timeout:g} s")
            raise SimStartError(f"the simulator did not start: {why}")
        self.ready_line = line.strip()
        addr = line.split()[2]  # udp:127.0.0.1:PORT
        self.kind, self.host, port = addr.split(":")
        self.port = int(port)
        # Drain both pipes from now on: a child whose unread pipe fills (~64 KB of warnings over a long campaign)
        # blocks on its next write and stops answering. The last lines are kept for :meth:`output`.
        self._tails = (collections.deque(maxlen=TAIL_LINES), collections.deque(maxlen=TAIL_LINES))
        self._drains = [threading.Thread(target=_drain, args=(pipe, tail), daemon=True)
                        for pipe, tail in zip((self.proc.stdout, self.proc.stderr), self._tails)]
        for t in self._drains:
            t.start()

    def output(self, timeout: float = 5.0) -> tuple[str, str]:
        """The child's last :data:`TAIL_LINES` lines of stdout and stderr after the ready line (complete once it
        has exited: call after :meth:`stop`)."""
        for t in self._drains:
            t.join(timeout if self.proc.poll() is not None else 0.0)
        return "".join(self._tails[0]), "".join(self._tails[1])

    def stop(self, sig: int = signal.SIGTERM, timeout: float = 10.0) -> int:
        """Signal the simulator, wait up to ``timeout`` s (then kill); returns its exit code."""
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        return self.proc.returncode

    def __enter__(self) -> "SimProcess":
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()
