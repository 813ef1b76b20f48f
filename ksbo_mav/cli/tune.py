"""`ksbo-mav tune`: tune a MAVLink vehicle's gains by safe BO over flown figure-8 trials (see ksbo_mav.campaign)."""

from __future__ import annotations

import argparse
from typing import Any

from ksbo_mav.campaign.settings import SETTING
from ksbo_mav.campaign.stops import EXIT, EXIT_TEXT
from ksbo_mav.cli.common import add_connection_args, endpoint_from_args, to_json
from ksbo_mav.errors import InputError
from ksbo_mav.opt import METHODS

#: Options that define a campaign; on --resume, one given with a different value than stored is refused.
_DEFINING = ("profile", "method", "budget", "seed", "prior", "n_prior", "confirm", "rate_hz", "warm_start",
             "early_stop", "min_trials", "trial_step", "wind_mps")
#: The option groups of `tune --help`, in the order a pilot needs them (connection first: always needed).
GROUPS = ("connection (exactly one)", "campaign directory", "profile and budget", "end of the campaign",
          "optimiser", "mission and drift", "help")


def _help(name: str, more: str = "") -> str:
    """An option's help: its setting's line from the declared table (ksbo_mav.campaign.settings), ``more``, and
    the default where it is a value of its own."""
    default = SETTING[name].default
    shown = "" if default is None or isinstance(default, (bool, dict)) else f" (default {default})"
    return (SETTING[name].help + more + shown).replace("%", "%%")


def add_parser(subparsers) -> None:
    # Types only here: what a value may be is the settings table's, one message whatever gave the value.
    p = subparsers.add_parser(
        "tune", add_help=False, help="tune a vehicle's gains over MAVLink (safe BO, journalled, restorable)",
        usage="ksbo-mav tune (DIR | --resume DIR) (--udp | --udp-out | --tcp | --serial ADDRESS) [options]",
        description="Snapshots every parameter to DIR, flies the baseline gains and then figure-8 trials chosen by "
                    "safe Bayesian optimisation (the search starts in a box around the vehicle's gains, the profile's "
                    "[trust_region], and grows towards the profile's limits, the autopilot's documented ranges, "
                    "where the best flights reach an edge; --dry-run shows both), writes the result "
                    "(DIR/result.json, DIR/report/index.html, "
                    "DIR/recommended.param) before the validation flights, restores the baseline gains (unless "
                    "--accept), lands (unless --end hold) and writes the result again. Ctrl-C aborts the trial, "
                    "restores the baseline and lands. Any stop leaves the report of what was flown and prints the "
                    "one command that continues. Every option is checked before anything is connected or written; "
                    "the settings, their defaults and allowed values: docs/settings.md.",
        epilog=EXIT_TEXT.replace("%", "%%"))
    g = add_connection_args(p)
    g.add_argument("--accept-link-loss-risk", action="store_true", help="PX4 on a link away from the vehicle (a "
                   "radio): fly anyway, although a lost link leaves the trial gains flying in PX4's failsafe")
    g.add_argument("--link-is-radio", action="store_true", help="treat this link as a radio even though it looks "
                   "local (a relay of a radio that sends no RADIO_STATUS)")
    g = p.add_argument_group(GROUPS[1])
    g.add_argument("dir", nargs="?", metavar="DIR", help="a new campaign's directory: snapshot, journal, trial logs, "
                   "report")
    g.add_argument("--resume", metavar="DIR", help="continue the campaign in DIR with its stored settings (after a "
                   "battery swap or a stop); refused if its profile now gives another search box or mission")
    g = p.add_argument_group(GROUPS[2])
    g.add_argument("--profile", help=_help("profile"))
    g.add_argument("--budget", type=int, metavar="N", help=_help("budget", "; --dry-run prints every flight"))
    g.add_argument("--early-stop", dest="early_stop", action=argparse.BooleanOptionalAction, default=None,
                   help=_help("early_stop", "; --no-early-stop: fly the budget"))
    g.add_argument("--min-trials", type=int, metavar="N", help=_help("min_trials"))
    g.add_argument("--dry-run", action="store_true", help="connect, print the flight plan (airspace, flights, "
                   "batteries), change nothing")
    g = p.add_argument_group(GROUPS[3])
    g.add_argument("--accept", action="store_true", help=_help("accept", " (`ksbo-mav accept DIR --force` "
                                                                          "writes them anyway)"))
    g.add_argument("--end", metavar="{land,hold}", default="land", help=_help("end"))
    g.add_argument("--onboard-guard", dest="onboard_guard", action=argparse.BooleanOptionalAction, default=None,
                   help="the onboard guard (ArduPilot Lua, needs SCR_ENABLE 1): baseline back on a lost link; "
                        "on unless --no-onboard-guard (said in the report)")
    g.add_argument("--validation", metavar="MODE", help=_help("validation"))
    g.add_argument("--json", action="store_true", help="print the final summary as JSON")
    g = p.add_argument_group(GROUPS[4])
    g.add_argument("--method", help=_help("method", "; or " + ", ".join(m for m in METHODS
                                                                            if m != "ksbo-adaptive")))
    g.add_argument("--seed", type=int, help=_help("seed"))
    g.add_argument("--option", action="append", metavar="KEY=VALUE",
                   help="optimiser option, repeatable, VALUE is JSON (e.g. max_aborts=4; backup_beta=null turns the "
                        "copter profiles' off); every option: docs/options.md")
    g.add_argument("--prior", metavar="KIND", help=_help("prior"))
    g.add_argument("--n-prior", type=int, metavar="N", help=_help("n_prior"))
    g.add_argument("--confirm", type=int, metavar="N", help=_help("confirm"))
    g.add_argument("--warm-start", metavar="EARLIER", help=_help("warm_start", "; --budget counts from the "
                                                                                "baseline on"))
    g = p.add_argument_group(GROUPS[5])
    g.add_argument("--trial-source", dest="trial_source", metavar="{onboard,ground}",
                   help=_help("trial_source"))
    g.add_argument("--trial-step", dest="trial_step", action=argparse.BooleanOptionalAction, default=None,
                   help=_help("trial_step"))
    g.add_argument("--rate", dest="rate_hz", type=int, metavar="HZ", help=_help("rate_hz", "; 50, 25, 20 or 10 "
                                                                                       "(docs/links.md)"))
    g.add_argument("--wind", dest="wind_mps", type=float, metavar="M/S", help=_help("wind_mps"))
    g.add_argument("--baseline-every", type=int, metavar="N", help=_help("baseline_every"))
    g.add_argument("--on-drift", metavar="ACTION", help=_help("on_drift"))
    p.add_argument_group(GROUPS[6]).add_argument("-h", "--help", action="help", help="show this help and exit")
    p.set_defaults(func=run)


class Display:
    """Live progress: one line per trial plus a progress bar (rich) over the budget, once it is settled."""

    def __init__(self, budget: int | None = None) -> None:
        from rich.console import Console
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

        self.console = Console(stderr=True, highlight=False)
        self.progress = Progress(TextColumn("[bold]tuning"), BarColumn(), MofNCompleteColumn(),
                                 TextColumn("{task.fields[status]}"), TimeElapsedColumn(), console=self.console,
                                 transient=True)
        self.task = None if budget is None else self.progress.add_task("tune", total=budget, status="")

    def settled(self, cfg: Any) -> None:
        """The campaign's settings are decided (the budget may be the vehicle profile's): the bar counts to it."""
        if self.task is None:
            self.task = self.progress.add_task("tune", total=cfg.budget, status="")

    def log(self, text: str) -> None:
        self.console.print(text, markup=False)

    def update(self, e: Any) -> None:
        f = e.flight
        mark = "ok" if f.outcome == "ok" else f"ABORT {f.outcome}"
        # The trial's role in the report's words (baseline, re-flight of trial 6, ...), then P and the counts:
        # P < 0 / aborted by the monitor / crashed / failed (not the gains); on a 3-D figure-8 what P is made of.
        rms, rough = f.score.get("rms_lap2_m"), f.score.get("rough_dps")
        made_of = (f"  (lap {rms:.3f} m" + ("" if rough is None else f", rough {rough:.2f} deg/s") + ")"
                   if rms is not None else "")
        self.console.print(f"trial {f.meta['trial']:3d} {e.role:<21} P {f.P:+.4f} {mark:<12} best {e.best_P:+.4f}  "
                           f"P<0 {e.n_unsafe} abort {e.n_aborted} crash {e.n_crashed} fail {e.n_failed}{made_of}",
                           highlight=False, markup=False, soft_wrap=True)
        if self.task is not None:
            self.progress.update(self.task, completed=e.n_opt, status=f"best P {e.best_P:+.4f}")


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
    from ksbo_mav.campaign.settings import check_setting

    given: dict[str, Any] = {k: getattr(args, k) for k in _DEFINING if getattr(args, k) is not None}
    if args.trial_source is not None:  # defines the campaign too: its scores are measured that way
        given["trial_source"] = args.trial_source
    if getattr(args, "option", None):
        given["options"] = dict(option_arg(o) for o in args.option)  # they define the campaign too
    # --end has a default, so it is always given; --accept only turns accepting on.
    resumable = {"end": args.end, **({"accept": True} if args.accept else {}),
                 **({"onboard_guard": args.onboard_guard} if args.onboard_guard is not None else {}),
                 **{k: getattr(args, k) for k in ("sysid", "compid", "baseline_every", "on_drift", "validation")
                    if getattr(args, k) is not None}}
    for name, value in {**given, **resumable}.items():
        check_setting(name, value)  # before a stored campaign is read: the value's own fault comes first
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
        f"{s.n_crashed}, failed for reasons unrelated to the gains {s.n_failed}; {s.wall_s:.0f} s "
        "for the prior, the trials and the confirmation")
    if s.search_end:
        log(s.search_end["text"])
    for name, v in t["values"].items():
        log(f"  {name:<16} {b['values'][name]:>12.6g} -> {v:<12.6g}")
    from ksbo_mav.campaign.report.writer import box_edge_lines

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
    from ksbo_mav.campaign.link_loss_policy import LinkLossChoice

    cfg = config_from_args(args)
    endpoint = endpoint_from_args(args)
    display = Display()
    camp = Campaign(cfg, endpoint, resume=bool(args.resume), log=display.log, progress=display.update,
                    connect_timeout=args.timeout, on_settled=display.settled,
                    link_loss=LinkLossChoice(args.accept_link_loss_risk, args.link_is_radio))
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
    checked = summary.validation or {}
    if checked.get("state") == "incomplete":
        display.log(f"tuned; validation incomplete: {checked['reason']}; `{checked['command']}` flies the rest")
        return EXIT["unvalidated"]
    return EXIT["ok"]
