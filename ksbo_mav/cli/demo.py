"""`ksbo-mav demo`: start the built-in simulator, tune it over real UDP on loopback, show before/after."""

from __future__ import annotations

import argparse
import select
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from ksbo_mav.cli.common import positive_int
from ksbo_mav.errors import VehicleError


def add_parser(subparsers) -> None:
    p = subparsers.add_parser("demo", help="tune the built-in simulator over MAVLink/UDP end to end (minutes)",
                              description="Starts `ksbo-mav sim --lockstep` in its own process, runs a short "
                                          "`ksbo-mav tune` campaign against it over UDP on 127.0.0.1, prints "
                                          "the before/after result and where the logs and plots are.")
    p.add_argument("--dir", help="campaign directory (default: a new directory under ./ksbo-demo-runs)")
    p.add_argument("--budget", type=positive_int, default=20, help="optimiser trials (20)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--method", default="ksbo")
    p.set_defaults(func=run)


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class SimProcess:
    """`python -m ksbo_sim.mavlink` in lockstep, sending to ``out_port`` (where the tuner listens)."""

    def __init__(self, out_port: int, *extra: str) -> None:
        cmd = [sys.executable, "-m", "ksbo_sim.mavlink", "--udp", "127.0.0.1:0", "--out", f"127.0.0.1:{out_port}",
               "--lockstep", *extra]
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        ready, _, _ = select.select([self.proc.stdout], [], [], 60)
        line = self.proc.stdout.readline() if ready else ""
        if not line.startswith("ksbo-sim ready"):
            self.stop()
            raise VehicleError(f"the simulator did not start: {line.strip() or self.proc.stderr.read()[-500:]}")
        self.ready_line = line.strip()
        self.port = int(line.split()[2].rsplit(":", 1)[1])

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


def run(args: argparse.Namespace) -> int:
    from ksbo_mav.cli.tune import Display, print_summary
    from ksbo_mav.mav.link import Endpoint
    from ksbo_mav.tune import Campaign, CampaignConfig

    if args.dir:
        d = Path(args.dir)
    else:
        Path("ksbo-demo-runs").mkdir(exist_ok=True)
        d = Path(tempfile.mkdtemp(prefix=time.strftime("demo-%Y%m%d-%H%M%S-"), dir="ksbo-demo-runs"))
    port = free_udp_port()
    print(f"starting the simulator (lockstep), tuner listening on udp 127.0.0.1:{port} ...")
    sim = SimProcess(port)
    print(sim.ready_line)
    try:
        cfg = CampaignConfig(dir=str(d), budget=args.budget, seed=args.seed, method=args.method, prior="sim")
        display = Display(cfg.budget)
        camp = Campaign(cfg, Endpoint("udp", "127.0.0.1", port), log=display.log, progress=display.update)
        t = time.monotonic()
        with display.progress:
            summary = camp.run()
        print_summary(summary, print)
        print(f"demo finished in {time.monotonic() - t:.0f} s; re-score a trial with: "
              f"ksbo-mav score {d}/trials/trial_000.tlog")
    finally:
        sim.stop()
    return 0
