"""The declared campaign settings: one row per setting of ``ksbo-mav tune`` (name, what it accepts, default, the
command-line option that gives it, one line of help), written like the optimiser's options
(:mod:`ksbo_mav.opt.constraints`). :class:`~ksbo_mav.campaign.config.CampaignConfig` takes its defaults from here
and checks every field against its row, so a bad value says the same line whether it came from the command line,
campaign.json or code; docs/settings.md is :func:`settings_markdown`."""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Real
from typing import Any

from ksbo_mav.errors import InputError
from ksbo_mav.opt import METHODS
from ksbo_mav.opt.constraints import BOOL, Choice, Interval

PRIOR_KINDS = ("auto", "sim", "local", "none")
END_MODES = ("land", "hold")
DRIFT_ACTIONS = ("stop", "continue")
#: Where a trial's figure-8 comes from: the onboard guard's script, or the tuner's setpoint stream.
TRIAL_SOURCES = ("onboard", "ground")
#: Validation flights after the tune (ksbo_mav.campaign.validation): none, the profile's repeats, or its full set.
VALIDATION_MODES = ("off", "quick", "full")
#: Mission rates (Hz) a campaign may fly at: setpoints carry feed-forward, so the autopilot fills in between them.
MISSION_RATES_HZ = (50, 25, 20, 10)


@dataclass(frozen=True)
class Text:
    """A non-empty string (a directory, a profile name or file); ``blank``: an empty one too."""

    blank: bool = False

    def accepts(self, v: Any) -> bool:
        return isinstance(v, str) and (self.blank or bool(v.strip()))

    def describe(self) -> str:
        return "a text" if self.blank else "a non-empty text"


@dataclass(frozen=True)
class Named:
    """A table of name = value (``numbers``: every value a finite number)."""

    numbers: bool = False

    def accepts(self, v: Any) -> bool:
        if not isinstance(v, dict) or not all(isinstance(k, str) for k in v):
            return False
        return not self.numbers or all(isinstance(x, Real) and not isinstance(x, bool) and math.isfinite(x)
                                       for x in v.values())

    def describe(self) -> str:
        return "a table of name = number" if self.numbers else "a table of name = value"


@dataclass(frozen=True)
class Unset:
    """Left unset (None: the row's default says who decides), or what ``inner`` accepts."""

    inner: Any

    def accepts(self, v: Any) -> bool:
        if v is None:
            return True
        if isinstance(self.inner, Interval) and self.inner.integer and not isinstance(v, int):
            return False
        return self.inner.accepts(v)

    def describe(self) -> str:
        return self.inner.describe()


#: Marks the one setting without a default (the campaign directory).
REQUIRED = object()


@dataclass(frozen=True)
class Setting:
    name: str
    accepts: Any  # a constraint: .accepts(value) and .describe()
    default: Any
    option: str | None  # the `tune` option that gives it; None: set by code (the demo, the benchmarks) only
    help: str

    def problem(self, value: Any) -> str | None:
        """None if ``value`` is allowed, else one line naming the setting, what it accepts and the value."""
        ok = self.accepts.accepts(value)
        if ok and isinstance(self.accepts, Interval) and self.accepts.integer:
            ok = isinstance(value, int)  # 3.0 from a hand-edited campaign.json would fail later in range()
        if ok:
            return None
        where = f" ({self.option})" if self.option and self.option.lstrip("-") != self.name else ""
        return f"{self.name}{where} must be {self.accepts.describe()}, got {value!r}"


def _whole(low: int, high: int | None = None) -> Interval:
    return Interval(low, high, integer=True)


SETTINGS: tuple[Setting, ...] = (
    Setting("dir", Text(blank=True), REQUIRED, "DIR", "the campaign directory: snapshot, journal, trial logs, report"),
    Setting("profile", Unset(Text()), None, "--profile",
            "vehicle profile, a name or a TOML file (unset: detected from the vehicle's identity)"),
    Setting("method", Choice(METHODS), "ksbo-adaptive", "--method",
            "optimiser: ksbo-adaptive learns its safety scale and caps aborted trials (docs/optimizer.md)"),
    Setting("budget", Unset(_whole(1)), None, "--budget",
            "optimiser trials incl. the baseline (unset: the profile's [campaign] budget, 10 on the copters)"),
    Setting("early_stop", Unset(BOOL), None, "--no-early-stop",
            "stop the search once the next flight's expected gain is below the re-flight noise (unset: the "
            "profile's; on for the copters)"),
    Setting("min_trials", Unset(_whole(1)), None, "--min-trials",
            "optimiser trials (baseline included) before it may stop early (unset: the profile's stop_min_trials)"),
    Setting("seed", _whole(0), 0, "--seed", "optimiser seed"),
    Setting("prior", Choice(PRIOR_KINDS), "auto", "--prior",
            "prior data: sim (simulator episodes), local (flown around the baseline), none; auto: the profile's"),
    Setting("n_prior", _whole(0), 0, "--n-prior", "prior size (0: 36 simulator episodes, 8 flown trials)"),
    Setting("confirm", _whole(0), 1, "--confirm", "re-fly the recommendation this many times"),
    Setting("warm_start", Unset(Text()), None, "--warm-start",
            "a finished campaign's directory to start from: its flights are the prior"),
    Setting("baseline_every", _whole(0), 7, "--baseline-every",
            "re-fly the baseline after this many trials and test for drift; 0: never"),
    Setting("on_drift", Choice(DRIFT_ACTIONS), "stop", "--on-drift",
            "when the vehicle drifted: stop (land, resumable) or continue (scores follow its trend)"),
    Setting("rate_hz", Unset(Choice(MISSION_RATES_HZ)), None, "--rate",
            "mission rate in Hz (unset: the profile's, lowered by the link check if the link cannot carry it)"),
    Setting("validation", Choice(VALIDATION_MODES), "quick", "--validation",
            "after the tune, fly baseline and recommendation alternately on the profile's [validation] manoeuvres "
            "(steps, hold, AUTO mission): quick, full (more flights) or off"),
    Setting("accept", BOOL, False, "--accept", "leave the best gains on the vehicle unless a confirmation failed"),
    Setting("end", Choice(END_MODES), "land", "--end", "after the campaign: land and disarm, or hold position"),
    Setting("onboard_guard", BOOL, True, "--onboard-guard",
            "install the onboard guard (ArduPilot Lua) that restores the baseline on a lost link; "
            "--no-onboard-guard flies without it"),
    Setting("trial_source", Choice(TRIAL_SOURCES), "onboard", "--trial-source",
            "the figure-8 flown by the onboard guard (ArduPilot) or streamed by the tuner"),
    Setting("trial_step", Unset(BOOL), None, "--trial-step",
            "each trial also flies a position step after its figure-8; leaning past the tilt limit there aborts "
            "it (unset: the profile's)"),
    Setting("wind_mps", Unset(Interval(0.0, 30.0)), None, "--wind",
            "the wind (m/s) known before takeoff: past the tilt limit in it, the limit is raised to the vehicle's "
            "own less 3 deg or the figure-8 scaled down (unset: none)"),
    Setting("settle_s", Interval(0.0), 1.0, None, "seconds of hover at the start point before a trial's figure-8"),
    Setting("sysid", Unset(_whole(1, 255)), None, "--sysid", "our MAVLink system id (unset: 245)"),
    Setting("compid", Unset(_whole(1, 255)), None, "--compid", "our MAVLink component id (unset: 191)"),
    Setting("safety", Named(numbers=True), {}, None, "abort thresholds over the profile's [safety] ones"),
    Setting("options", Named(), {}, "--option", "optimiser options over the profile's and the defaults "
                                                "(docs/options.md)"),
)
SETTING = {s.name: s for s in SETTINGS}


def check_setting(name: str, value: Any) -> None:
    """InputError (one line) unless ``value`` is allowed for the setting ``name``."""
    why = SETTING[name].problem(value)
    if why:
        raise InputError(why)


def settings_markdown() -> str:
    """docs/settings.md: every campaign setting, its option, default, what it accepts and what it does."""
    rows = ["| setting | option | default | accepts | what it does |", "|---|---|---|---|---|"]
    for s in SETTINGS:
        default = "(required)" if s.default is REQUIRED else _md(s.default)
        rows.append(f"| `{s.name}` | {f'`{s.option}`' if s.option else ''} | {default} | {s.accepts.describe()} "
                    f"| {s.help} |")
    return "\n".join(rows)


def _md(v: Any) -> str:
    if v is None:
        return "unset"
    if isinstance(v, bool):
        return "true" if v else "false"
    return "{}" if v == {} else str(v)
