"""`ksbo-mav tune`: tune a MAVLink vehicle's gains by safe BO over flown figure-8 trials (see ksbo_mav.campaign)."""

from __future__ import annotations

import argparse
from typing import Any

from ksbo_mav.cli.common import add_connection_args, endpoint_from_args, positive_int, to_json
from ksbo_mav.errors import InputError

#: Options that define a campaign; on --resume, one given with a different value than stored is refused.
_DEFINING = ("profile", "method", "budget", "seed", "prior", "n_prior", "confirm", "widen", "rate_hz", "warm_start")


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "tune", help="tune a vehicle's gains over MAVLink (safe BO, journalled, restorable)",
        description="Connects, snapshots every parameter to DIR before any write, takes off if the vehicle is on "
                    "the ground, flies the baseline gains and then figure-8 trials chosen by safe Bayesian "
                    "optimisation with kernel selection, restores the baseline gains (unless --accept) and lands "
                    "(unless --end hold), and writes a report page DIR/report/index.html (verdict, plots, every trial; "
                    "`ksbo-mav report DIR` rewrites it). Ctrl-C aborts the current trial, restores the baseline and "
                    "lands. "
                    "Every option is checked before anything is connected or written; --dry-run prints the "
                    "flight plan (airspace, flights, batteries) and changes nothing.")
    p.add_argument("dir", nargs="?", metavar="DIR", help="campaign directory (new)")
    p.add_argument("--resume", metavar="DIR", help="continue the campaign in DIR (after a crash or battery swap) with "
                   "its stored settings; refused if its profile now gives another search box or mission")
    add_connection_args(p)
    p.add_argument("--profile", help="vehicle profile (default: from the vehicle's identity)")
    p.add_argument("--method", help="optimiser: ksbo-adaptive (default: safe BO that learns its safety scale, "
                                    "treats aborted trials as censored, caps them at max_aborts and re-flies its "
                                    "best candidates; on profiles whose backup covers the trials it also explores "
                                    "beyond the certified set), ksbo (the paper's method, no abort cap unless "
                                    "--option max_aborts=N; on the simulated planar task it aborts fewer trials "
                                    "but, in MAVLink campaigns on the built-in vehicle from random moving starts, its "
                                    "recommendations re-fly lower; BENCHMARKS.md), standard, safeopt, ...")
    p.add_argument("--budget", type=positive_int, help="optimiser trials incl. the baseline (default: the "
                   "profile's, 10 on the copters, i.e. 12 flights, one pack; 30 elsewhere); the baseline "
                   "re-flights (--baseline-every), the confirmation and a flown prior's trials come on top: "
                   "--dry-run prints the total. On the copters 12 flights gave at least 90 %% of a 40-flight "
                   "campaign's cut in 12 of 12 benchmark campaigns, by the fifth flight (BENCHMARKS.md)")
    p.add_argument("--seed", type=int, help="optimiser seed (default 0)")
    p.add_argument("--prior", choices=("auto", "sim", "local", "none"),
                   help="prior data for kernel selection and the model: simulator episodes in process (sim: the "
                        "planar simulator, or our JSBSim copter for the ardupilot-copter and px4-copter profiles; "
                        "the default for those, nothing flown), a local LHS around the baseline flown on the "
                        "vehicle (local, the default for other profiles), or none")
    p.add_argument("--n-prior", type=int, metavar="N", help="prior size (default 36 sim / 8 local)")
    p.add_argument("--option", action="append", metavar="KEY=VALUE",
                   help="optimiser option (repeatable; VALUE is JSON), e.g. --option max_aborts=4. The copter "
                        "profiles ([safety] backup_covers_trials) give ksbo-adaptive backup_beta=0.5: it may fly "
                        "uncertified gains the monitor's backup covers; --option backup_beta=null turns that off. "
                        "Every option with its default and allowed values: docs/options.md (an unknown KEY prints "
                        "the list)")
    p.add_argument("--confirm", type=int, metavar="N", help="re-fly the recommendation N times (default 1)")
    p.add_argument("--rate", dest="rate_hz", type=int, metavar="HZ",
                   help="fly the mission at HZ (50, 25, 20 or 10: setpoints with feed-forward and telemetry alike) "
                        "instead of the profile's rate; without it the link check lowers the rate by itself when "
                        "the link cannot carry the profile's (docs/links.md)")
    p.add_argument("--baseline-every", type=int, metavar="N",
                   help="re-fly the baseline gains after every N trials (optimiser and flown prior) and test "
                        "whether the vehicle changed (drift): if its tracking at the same gains got clearly "
                        "worse, land and stop, resumable (default 7; 0: never)")
    p.add_argument("--on-drift", choices=("stop", "continue"),
                   help="when the vehicle changed at the baseline gains: stop (default: land, restore the baseline, "
                        "resumable after a check of the vehicle) or continue, scoring every trial against the "
                        "baseline as last re-flown, carried along its trend")
    p.add_argument("--warm-start", metavar="EARLIER", help="start from the finished campaign in EARLIER (same profile "
                   "or vehicle, same gains): its flights are the prior (no flown prior), its recommendation is "
                   "re-flown right after the baseline so that the vehicle's condition now is known, and --budget "
                   "counts from the baseline on")
    p.add_argument("--widen", action="store_const", const=True, help="when the recommendation ends on a bound of "
                   "the search box, move that bound out stepwise (never past the gain's documented range) and search "
                   "on from the recommendation; as the profile's [trust_region] widen = true (docs/profiles.md)")
    p.add_argument("--accept", action="store_true", help="leave the best gains on the vehicle at the end (not if a "
                   "confirmation flight of them aborted, crashed or scored P < 0: then the baseline is restored and "
                   "`ksbo-mav accept DIR --force` writes them anyway)")
    p.add_argument("--end", choices=("land", "hold"), default="land",
                   help="after the campaign: land and disarm (default) or hold position where it is")
    p.add_argument("--dry-run", action="store_true", help="connect, print the plan, change nothing")
    p.add_argument("--json", action="store_true", help="print the final summary as JSON")
    p.set_defaults(func=run)


class Display:
    """Live progress: one line per trial plus a progress bar (rich)."""

    def __init__(self, budget: int | None) -> None:
        from rich.console import Console
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

        self.console = Console(stderr=True, highlight=False)
        self.progress = Progress(TextColumn("[bold]tuning"), BarColumn(), MofNCompleteColumn(),
                                 TextColumn("{task.fields[status]}"), TimeElapsedColumn(), console=self.console,
                                 transient=True)
        self.task = self.progress.add_task("tune", total=budget, status="")

    def log(self, text: str) -> None:
        self.console.print(text, markup=False)

    def update(self, e: Any, budget: int | None = None) -> None:
        f = e.flight
        mark = "ok" if f.outcome == "ok" else f"ABORT {f.outcome}"
        # One line of at most 80 columns: P < 0 / aborted by the monitor / crashed / failed (not the gains).
        self.console.print(f"{e.kind:>7} trial {f.meta['trial']:3d}  P {f.P:+.4f} {mark:<12} best {e.best_P:+.4f}  "
                           f"P<0 {e.n_unsafe} abort {e.n_aborted} crash {e.n_crashed} fail {e.n_failed}",
                           highlight=False, markup=False, soft_wrap=True)
        self.progress.update(self.task, completed=e.n_opt, status=f"best P {e.best_P:+.4f}",
                             **({"total": budget} if budget else {}))


def option_arg(text: str) -> tuple[str, Any]:
    """``KEY=VALUE`` → (key, value); VALUE is parsed as JSON (a bare word stays a string)."""
    import json

    key, sep, value = text.partition("=")
    if not sep or not key.strip():
        raise InputError(f"--option expects KEY=VALUE, got {text!r}")
    try:
        return key.strip(), json.loads(value)
    except json.JSONDecodeError:
        return key.strip(), value


def config_from_args(args: argparse.Namespace):
    """The campaign settings, validated (InputError, one line) before anything is connected or written. What the
    command line gives wins over the stored campaign's (on --resume) and the defaults
    (:func:`ksbo_mav.campaign.config.resolve`); on --resume only the settings that do not change what the optimiser
    has seen may differ."""
    from ksbo_mav.campaign import CampaignConfig, CampaignDir
    from ksbo_mav.campaign.config import resolve

    given: dict[str, Any] = {k: getattr(args, k) for k in _DEFINING if getattr(args, k) is not None}
    if getattr(args, "option", None):
        given["options"] = dict(option_arg(o) for o in args.option)  # they define the campaign too
    # --end has a default, so it is always given; --accept only turns accepting on.
    resumable = {"end": args.end, **({"accept": True} if args.accept else {}),
                 **{k: getattr(args, k) for k in ("sysid", "compid", "baseline_every", "on_drift")
                    if getattr(args, k) is not None}}
    if args.resume:
        if args.dir:
            raise InputError("give either DIR (a new campaign) or --resume DIR, not both")
        d = CampaignDir.at(args.resume)
        stored = CampaignConfig.from_saved(d.read_settings()["config"], str(d.config))
        clash = [f"--{k.replace('_', '-')} {v} (campaign: {getattr(stored, k)})" for k, v in given.items()
                 if getattr(stored, k) != v]
        if clash:
            raise InputError(f"--resume {args.resume}: {', '.join(clash)} would change the campaign; resume it "
                             "as it was (or start a new one in another directory)")
        return CampaignConfig(**resolve(command_line={"dir": args.resume, **resumable},
                                        stored=stored.to_dict())).validate()
    if not args.dir:
        raise InputError("give a campaign directory DIR (or --resume DIR)")
    cfg = CampaignConfig(**resolve(command_line={"dir": args.dir, **given, **resumable})).validate()
    if not args.dry_run and CampaignDir.at(args.dir).exists():
        raise InputError(f"{args.dir} already holds a campaign; use --resume {args.dir} or another directory")
    return cfg


def print_summary(s: Any, log) -> None:
    b, t = s.baseline, s.best
    rms = f", lap-2 RMS {b['rms_m']:.3f} m" if b.get("rms_m") is not None else ""
    log(f"before: P = {b['P']:+.4f}  (baseline gains, trial {b['trial']}{rms})")
    pc = t["P_confirm"]
    log(f"after:  P = {pc:+.4f}  (recommended gains re-flown; model mean {t['P_model']:+.4f})"
        if pc is not None else f"after:  model mean P = {t['P_model']:+.4f}")
    log(f"trials {s.n_trials}: unsafe (P < 0) {s.n_unsafe}, aborted by the monitor {s.n_aborted}, crashed "
        f"{s.n_crashed}, failed for reasons unrelated to the gains {s.n_failed}; {s.wall_s:.0f} s")
    for name, v in t["values"].items():
        log(f"  {name:<16} {b['values'][name]:>12.6g} -> {v:<12.6g}")
    from ksbo_mav.campaign.report import box_edge_lines

    for line in box_edge_lines(s.dir, s.to_dict()):
        log(f"search box: {line}")
    held = ("the best gains (accepted)" if s.accepted else "the baseline gains (restored, verified"
            + (f"; --accept refused: {s.accept_refused})" if s.accept_refused else ")"))
    log("vehicle holds: " + held
        + {"landed": "; landed and disarmed", "holding": "; hovering (--end hold)"}.get(s.ended, ""))
    log(f"logs: {s.dir}/trials  journal: {s.dir}/journal.jsonl  result: {s.dir}/result.json")
    for name, path in s.plots.items():
        if name != "page":
            log(f"plot ({name}): {path}" if path != "none" else f"plot ({name}): none - no unsafe, aborted or failed "
                "trial")
    if s.plots.get("page"):
        log(f"report: {s.plots['page']}")


def run(args: argparse.Namespace) -> int:
    from ksbo_mav.campaign import Campaign

    cfg = config_from_args(args)
    endpoint = endpoint_from_args(args)
    display = Display(cfg.budget)
    camp = Campaign(cfg, endpoint, resume=bool(args.resume), log=display.log,
                    progress=lambda e: display.update(e, camp.cfg.budget), connect_timeout=args.timeout)
    if args.dry_run:
        print(camp.dry_run())
        print("dry run: nothing was written to the vehicle or to disk")
        return 0
    with display.progress:
        summary = camp.run()
    if args.json:
        print(to_json(summary.to_dict()))
    else:
        print_summary(summary, print)
    return 0
