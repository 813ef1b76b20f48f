"""Start and stop the link emulator (:mod:`ksbo_sim.linkemu`) as a child process, for tests and benchmarks."""

from __future__ import annotations

import json
import select
import signal
import subprocess
import sys

from ksbo_sim.errors import SimStartError


class LinkEmulator:
    """``python -m ksbo_sim.linkemu`` between ``vehicle`` and ``ground`` (see that module), ready when the
    constructor returns; ``vehicle_port`` / ``ground_port`` are the ports it bound. :meth:`stop` returns the
    counters of both directions (``{"down": {...}, "up": {...}}``)."""

    def __init__(self, vehicle: str, ground: str, shape: str = "", startup_timeout: float = 60.0) -> None:
        # (60 s, as the simulator's: a Python start on a loaded 2-core machine took more than 10 s)
        self.proc = subprocess.Popen([sys.executable, "-m", "ksbo_sim.linkemu", "--vehicle", vehicle, "--ground",
                                      ground, "--shape", shape], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     text=True)
        ready, _, _ = select.select([self.proc.stdout], [], [], startup_timeout)
        line = self.proc.stdout.readline() if ready else ""
        if not line.startswith("ksbo-linkemu ready"):
            self.proc.kill()
            err = self.proc.stderr.read().strip()
            raise SimStartError(f"link emulator did not start: {err or line.strip() or 'no ready line'}")
        words = dict(w.split(":", 1) for w in line.split()[2:4])
        self.vehicle_port, self.ground_port = int(words["vehicle"]), int(words["ground"])
        self.ready_line = line.strip()

    def cut(self) -> None:
        """Cut the link: from now on every frame either way is dropped (SIGUSR1), until :meth:`reconnect`."""
        self.proc.send_signal(signal.SIGUSR1)

    def reconnect(self) -> None:
        """End a :meth:`cut` (SIGUSR2): frames pass again."""
        self.proc.send_signal(signal.SIGUSR2)

    def stop(self, timeout: float = 5.0) -> dict:
        if self.proc.poll() is None:
            self.proc.terminate()
        try:
            out, _ = self.proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            out, _ = self.proc.communicate()
        for line in out.splitlines():
            if line.startswith("ksbo-linkemu stats "):
                return json.loads(line.split(" ", 2)[2])
        return {}

    def __enter__(self) -> "LinkEmulator":
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()
