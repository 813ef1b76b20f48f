"""`ksbo-mav demo`: start the built-in simulator, tune it over real UDP on loopback, show before/after."""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

from ksbo_mav.campaign.config import CampaignConfig
from ksbo_mav.cli.common import positive_int
from ksbo_mav.errors import VehicleError
from ksbo_sim.errors import SimStartError
from ksbo_sim.process import SimProcess, free_udp_port


def add_parser(subparsers) -> None:
    p = subparsers.add_parser("demo", help="tune the built-in simulator over MAVLink/UDP end to end (minutes)",
                              description="Starts `ksbo-mav sim --lockstep` in its own process, runs a short "
                                          "`ksbo-mav tune` campaign against it over UDP on 127.0.0.1, prints "
                                          "the before/after result and where the logs and plots are.")
    p.add_argument("--dir", help="campaign directory (default: a new directory under ./ksbo-demo-runs)")
    p.add_argument("--budget", type=positive_int, default=20, help="optimiser trials (20)")
    p.add_argument("--seed", type=int, default=0, help="optimiser seed (0)")
    p.add_argument("--method", default=CampaignConfig.method,
                   help=f"optimiser (default {CampaignConfig.method}, as for `tune`; --method ksbo is the paper's "
                        "method), its kernel selected on a prior of simulator episodes")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ksbo_mav.cli.tune import Display, print_summary
    from ksbo_mav.mav.link import Endpoint
    from ksbo_mav.campaign import Campaign, CampaignConfig

    # The settings are checked before anything starts: a bad --method is one line, not a flown baseline.
    # (The directory is filled in once the simulator runs; validate does not look at it.)
    checked = CampaignConfig(dir="", budget=args.budget, seed=args.seed, method=args.method, prior="sim").validate()
    port = free_udp_port()
    print(f"starting the simulator (lockstep), tuner listening on udp 127.0.0.1:{port} ...")
    try:
        sim = SimProcess("--lockstep", out_port=port)
    except SimStartError as exc:
        raise VehicleError(str(exc)) from None
    print(sim.ready_line)
    try:
        if args.dir:  # created only once the simulator runs: a failed start leaves nothing behind
            d = Path(args.dir)
        else:
            Path("ksbo-demo-runs").mkdir(exist_ok=True)
            d = Path(tempfile.mkdtemp(prefix=time.strftime("demo-%Y%m%d-%H%M%S-"), dir="ksbo-demo-runs"))
        cfg = dataclasses.replace(checked, dir=str(d))
        display = Display(cfg.budget)
        camp = Campaign(cfg, Endpoint("udp", "127.0.0.1", port), log=display.log, progress=display.update)
        t = time.monotonic()
        with display.progress:
            summary = camp.run()
        print_summary(summary, print)
        # Not the campaign's own figure above (prior, flights and landing): this one adds connecting, the parameter
        # download, the link check, the snapshot and the report.
        print(f"demo: {time.monotonic() - t:.0f} s in all, from connecting to the written report; re-score a "
              "trial with: "
              f"ksbo-mav score {d}/trials/trial_000.tlog")
    finally:
        sim.stop()
    return 0
