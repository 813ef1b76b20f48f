"""Command-line entry point: `ksbo-mav <command> ...`.

Each command lives in its own module of this package, exposing ``add_parser(subparsers)`` (registers the
subcommand and sets ``func=run``) and ``run(args) -> int``. User errors are raised as
:class:`ksbo_mav.errors.KsboError` and printed as one line, never as a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from ksbo_mav.errors import CampaignPaused, KsboError

#: Command modules, in the order `--help` lists them.
COMMANDS: tuple[str, ...] = ("evaluate", "sim", "prior", "select", "tune", "report", "score", "compare", "check",
                             "validate", "restore", "accept", "demo", "sim-pilot")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="ksbo-mav",
        description=(
            "Tune a multicopter's position-loop PID gains by safe Bayesian optimisation with kernel "
            "selection (Zheng et al., arXiv 2411.07573), on a built-in simulator or a MAVLink vehicle."
        ),
    )
    from ksbo_mav import __version__

    parser.add_argument("--version", action="version", version=f"ksbo-mav {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"ksbo_mav.cli.{name.replace('-', '_')}").add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except CampaignPaused as exc:  # a pack to swap, a failsafe: a normal stop, resumable
        print(f"stopped: {exc}", file=sys.stderr)
        return 3
    except KsboError as exc:  # the commands that run a simulator turn its errors into these
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into `head` and the like
        sys.stderr.close()
        return 0
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
