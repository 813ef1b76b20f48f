"""`ksbo-mav tune`: tune a MAVLink vehicle's gains by safe BO over flown figure-8 trials (see ksbo_mav.tune)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from ksbo_mav.cli.common import add_connection_args, endpoint_from_args, positive_int, to_json
from ksbo_mav.errors import InputError


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "tune", help="tune a vehicle's gains over MAVLink (safe BO, journalled, restorable)",
        description="Connects, snapshots every parameter to DIR before any write, flies figure-8 trials chosen by "
                    "safe Bayesian optimisation with kernel selection, and restores the baseline gains at the end "
                    "unless --accept. Ctrl-C aborts the current trial and restores the baseline.")
    p.add_argument("dir", nargs="?", metavar="DIR", help="campaign directory (new)")
    p.add_argument("--resume", metavar="DIR", help="continue the campaign in DIR (after a crash or battery swap)")
    add_connection_args(p)
    p.add_argument("--profile", help="vehicle profile (default: from the vehicle's identity)")
    p.add_argument("--method", default="ksbo", help="optimiser (ksbo, standard, safeopt, linebo; default ksbo)")
    p.add_argument("--budget", type=positive_int, default=30, help="optimiser trials incl. the baseline (30)")
    p.add_argument("--seed", type=int, default=0, help="optimiser seed (0)")
    p.add_argument("--prior", default="auto", choices=("auto", "sim", "local", "none"),
                   help="kernel-selection prior: simulator episodes (sim, default for the built-in vehicle) or "
                        "a local LHS around the baseline flown on the vehicle (local)")
    p.add_argument("--n-prior", type=int, default=0, metavar="N", help="prior size (default 36 sim / 8 local)")
    p.add_argument("--confirm", type=int, default=1, metavar="N", help="re-fly the recommendation N times (1)")
    p.add_argument("--accept", action="store_true", help="leave the best gains on the vehicle at the end")
    p.add_argument("--end", choices=("land", "hold"), default="land", help="after the campaign (land)")
    p.add_argument("--dry-run", action="store_true", help="connect, print the plan, change nothing")
    p.add_argument("--json", action="store_true", help="print the final summary as JSON")
    p.set_defaults(func=run)


class Display:
    """Live progress: one line per trial plus a progress bar (rich)."""

    def __init__(self, budget: int) -> None:
        from rich.console import Console
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

        self.console = Console(stderr=True, highlight=False)
        self.progress = Progress(TextColumn("[bold]tuning"), BarColumn(), MofNCompleteColumn(),
                                 TextColumn("{task.fields[status]}"), TimeElapsedColumn(), console=self.console,
                                 transient=True)
        self.task = self.progress.add_task("tune", total=budget, status="")
        self.best = float("-inf")

    def log(self, text: str) -> None:
        self.console.print(text, markup=False)

    def update(self, info: dict[str, Any]) -> None:
        f, journal = info["flight"], info["journal"]
        opt = journal.of("opt")
        if info["kind"] == "opt" and f.P > self.best:
            self.best = f.P
        unsafe = sum(e["P"] < 0 for e in opt)
        aborted = sum(e["outcome"] != "ok" for e in journal.entries)
        mark = "ok" if f.outcome == "ok" else f"ABORT {f.outcome}"
        self.console.print(f"{info['kind']:>7} trial {f.meta['trial']:3d}  P = {f.P:+.4f}  {mark:<12} "
                           f"best {self.best:+.4f}  unsafe {unsafe}  aborted {aborted}", highlight=False)
        self.progress.update(self.task, completed=len(opt), status=f"best P {self.best:+.4f}")


def _config(args: argparse.Namespace):
    from ksbo_mav.tune import CampaignConfig

    if args.resume:
        try:
            saved = json.loads(Path(args.resume, "campaign.json").read_text())["config"]
        except (OSError, KeyError, json.JSONDecodeError):
            raise InputError(f"{args.resume} holds no readable campaign.json to resume") from None
        cfg = CampaignConfig(**saved)
        cfg.dir = args.resume
        cfg.accept = cfg.accept or args.accept
        cfg.sysid = args.sysid if args.sysid is not None else cfg.sysid
        cfg.compid = args.compid if args.compid is not None else cfg.compid
        return cfg
    if not args.dir:
        raise InputError("give a campaign directory DIR (or --resume DIR)")
    return CampaignConfig(dir=args.dir, profile=args.profile, method=args.method, budget=args.budget,
                          seed=args.seed, prior=args.prior, n_prior=args.n_prior, confirm=args.confirm,
                          accept=args.accept, end=args.end, sysid=args.sysid, compid=args.compid)


def print_summary(s: dict[str, Any], log) -> None:
    b, t = s["baseline"], s["best"]
    rms = f", lap-2 RMS {b['rms_m']:.3f} m" if b.get("rms_m") is not None else ""
    log(f"before: P = {b['P']:+.4f}  (baseline gains, trial {b.get('trial')}{rms})")
    pc = t["P_confirm"]
    log(f"after:  P = {pc:+.4f}  (recommended gains re-flown; model mean {t['P_model']:+.4f})"
        if pc is not None else f"after:  model mean P = {t['P_model']:+.4f}")
    log(f"trials {s['n_trials']}, unsafe {s['n_unsafe']}, aborted {s['n_aborted']} "
        f"(of which {s.get('n_failed', 0)} for reasons unrelated to the gains), {s['wall_s']:.0f} s")
    for name, v in t["values"].items():
        log(f"  {name:<16} {b['values'][name]:>12.6g} -> {v:<12.6g}")
    log("vehicle holds: " + ("the best gains (accepted)" if s["accepted"] else "the baseline gains (restored, verified)"))
    log(f"logs: {s['dir']}/trials  journal: {s['dir']}/journal.jsonl  result: {s['dir']}/result.json")
    for name, path in s.get("plots", {}).items():
        log(f"plot ({name}): {path}")


def run(args: argparse.Namespace) -> int:
    from ksbo_mav.tune import Campaign

    cfg = _config(args)
    endpoint = endpoint_from_args(args)
    display = Display(cfg.budget)
    camp = Campaign(cfg, endpoint, resume=bool(args.resume), log=display.log, progress=display.update,
                    connect_timeout=args.timeout)
    if args.dry_run:
        out = camp.run(dry_run=True)
        print(out["plan"])
        print("dry run: nothing was written to the vehicle")
        return 0
    with display.progress:
        summary = camp.run()
    if args.json:
        print(to_json(summary))
    else:
        print_summary(summary, print)
    return 0
