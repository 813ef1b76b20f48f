"""A campaign's settings: one typed object whose every field is declared once
(:data:`ksbo_mav.campaign.settings.SETTINGS`: what it accepts, its default), checked before anything connects or is
written; :func:`resolve`, the one place that decides which value a setting takes when several places give one, and
:func:`settle`, which applies it once the vehicle's profile is known."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, replace
from typing import Any

from ksbo_mav.campaign.settings import REQUIRED, SETTING, SETTINGS, check_setting
from ksbo_mav.errors import InputError

#: Default prior sizes: simulator episodes (computed, free) and flown local prior trials.
PRIOR_SIZES = {"sim": 36, "local": 8}
#: Settings that may differ on ``--resume`` (they do not change what the optimiser has seen).
RESUMABLE = ("dir", "accept", "end", "sysid", "compid", "validation")


def _default(name: str) -> Any:
    """The dataclass default of a setting, from its declaration (a fresh dict for a table)."""
    d = SETTING[name].default
    if d is REQUIRED:
        return field()
    return field(default_factory=lambda: dict(d)) if isinstance(d, dict) else field(default=d)


@dataclass
class CampaignConfig:
    """What ``ksbo-mav tune`` was asked to do; meaning, allowed values and defaults: ``SETTINGS``.
    :meth:`validate` checks every field once."""

    dir: str = _default("dir")
    profile: str | None = _default("profile")
    method: str = _default("method")
    budget: int | None = _default("budget")  # None: the profile's, decided by settle() once connected
    early_stop: bool | None = _default("early_stop")  # None: the profile's, decided by settle()
    min_trials: int | None = _default("min_trials")  # None: the profile's, decided by settle()
    seed: int = _default("seed")
    prior: str = _default("prior")
    n_prior: int = _default("n_prior")  # 0 = default for the prior kind (prior_size)
    confirm: int = _default("confirm")
    warm_start: str | None = _default("warm_start")
    baseline_every: int = _default("baseline_every")
    on_drift: str = _default("on_drift")
    rate_hz: int | None = _default("rate_hz")  # None: the profile's; settle() decides the rate flown
    validation: str = _default("validation")  # validation flights after the tune: off, quick, full
    accept: bool = _default("accept")
    end: str = _default("end")
    onboard_guard: bool = _default("onboard_guard")
    trial_source: str = _default("trial_source")
    trial_step: bool | None = _default("trial_step")  # None: the profile's, decided by settle()
    wind_mps: float | None = _default("wind_mps")  # None: no wind declared, no prediction
    settle_s: float = _default("settle_s")
    sysid: int | None = _default("sysid")
    compid: int | None = _default("compid")
    safety: dict[str, float] = _default("safety")
    options: dict[str, Any] = _default("options")

    def validate(self) -> "CampaignConfig":
        """InputError naming the bad setting and what it accepts; also loads the profile (if named), the warm
        start's campaign, and checks the optimiser options against their own declarations."""
        from ksbo_mav.opt.options import options_for
        from ksbo_mav.profiles import load_profile

        for s in SETTINGS:
            check_setting(s.name, getattr(self, s.name))
        if self.warm_start is not None:
            from ksbo_mav.campaign.layout import CampaignDir

            CampaignDir.at(self.warm_start).read_result()  # InputError unless a finished campaign
            if self.budget is not None and self.budget < 2:
                raise InputError("a warm start needs --budget 2 or more (the baseline and the earlier recommendation)")
        if self.profile is not None:
            load_profile(self.profile)  # InputError if bad
        options_for(self.method, optimizer_options("none", self.options))
        return self

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_saved(cls, saved: Any, where: str) -> "CampaignConfig":
        """The config stored in campaign.json; InputError for unknown keys or bad values."""
        if not isinstance(saved, dict):
            raise InputError(f"{where}: 'config' is not an object")
        known = {f.name for f in dataclasses.fields(cls)}
        saved = {k: v for k, v in saved.items() if k not in RETIRED}
        unknown = sorted(set(saved) - known)
        if unknown:
            raise InputError(f"{where}: unknown campaign setting(s) {', '.join(unknown)}")
        if "dir" not in saved:
            raise InputError(f"{where}: 'config' lacks 'dir'")
        try:
            return cls(**saved).validate()
        except TypeError as exc:
            raise InputError(f"{where}: {exc}") from None

    def conflicts(self, other: "CampaignConfig") -> list[str]:
        """Settings (other than :data:`RESUMABLE`) where ``other`` differs from this stored config."""
        a, b = self.to_dict(), other.to_dict()
        return [k for k in a if k not in RESUMABLE and a[k] != b[k]]


def resolve(command_line: Mapping[str, Any] | None = None, stored: Mapping[str, Any] | None = None,
            profile: Mapping[str, Any] | None = None, default: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Settings by precedence: the command line's, else the stored campaign's (a resume), else what the vehicle
    profile implies, else the default.

    Each level maps the settings it gives to their values; a setting a level leaves out is decided by the next
    one. ``None`` is a value (``--option backup_beta=null`` turns the profile's ``backup_beta`` off): callers
    leave out what was not given."""
    out: dict[str, Any] = {}
    for level in (default, profile, stored, command_line):
        out.update(level or {})
    return out


#: Profiles whose vehicle class has an in-process simulator (the planar task; our JSBSim copter for the copters):
#: their "auto" prior is simulator episodes, nothing flown.
SIM_PRIOR_PROFILES = ("sim-planar", "ardupilot-copter", "px4-copter")


@dataclass(frozen=True)
class MissionRate:
    """The rate (Hz) a campaign flies its mission at (setpoints and telemetry), and whether the link check may
    step it down (only a new campaign's rate that nobody asked for: the profile's)."""

    hz: int
    lowerable: bool


def settle(cfg: CampaignConfig, profile: Any, stored: Mapping[str, Any] | None = None
           ) -> tuple[CampaignConfig, MissionRate]:
    """The settings that depend on the vehicle, decided once its profile is known and before anything is built
    from them (the progress display, the link check, the optimiser); the one place that decides them.

    ``cfg`` holds what the command line gives over the stored campaign's settings (``config_from_args``, by
    :func:`resolve`); ``stored`` is campaign.json on a resume (None: a new campaign). The budget: ``cfg``'s, else
    the profile's ``[campaign] budget``; the same for ``early_stop``, ``min_trials`` and ``trial_step`` (its
    ``early_stop``, ``stop_min_trials`` and ``trial_step``; a resumed campaign stored without ``trial_step`` flew
    none). The mission rate: ``--rate``, else the rate the campaign flew at (the link check may have lowered it
    when it started), else the profile's."""
    budget = resolve(command_line={} if cfg.budget is None else {"budget": cfg.budget},
                     profile={"budget": int(profile.campaign_spec.budget)})["budget"]
    flown = ((stored or {}).get("mission") or {}).get("rate_hz")
    rate = resolve(command_line={"rate_hz": cfg.rate_hz} if cfg.rate_hz else {},
                   stored={"rate_hz": int(flown)} if flown else {},
                   profile={"rate_hz": int(profile.mission_spec.rate_hz)})["rate_hz"]
    spec = profile.campaign_spec
    step = cfg.trial_step
    if step is None and stored is not None and "trial_step" not in (stored.get("config") or {}):
        step = False  # a campaign recorded before the setting existed flew its figure-8 alone
    given = (("early_stop", cfg.early_stop), ("min_trials", cfg.min_trials), ("trial_step", step))
    stop = resolve(command_line={k: v for k, v in given if v is not None},
                   profile={"early_stop": bool(spec.early_stop), "min_trials": int(spec.stop_min_trials),
                            "trial_step": bool(spec.trial_step)})
    settled = replace(cfg, budget=budget, **stop).validate()
    if settled.trial_step:  # a profile the step cannot be flown on is refused before anything is written
        from ksbo_mav.mav.monitor import limits_from_profile
        from ksbo_mav.mav.trial_step import TrialStep

        TrialStep.from_profile(profile, limits_from_profile(profile, settled.safety))
    return settled, MissionRate(rate, lowerable=stored is None and not cfg.rate_hz)


def prior_kind(cfg: CampaignConfig, profile: Any) -> str:
    """The prior a campaign flies: ``cfg.prior`` (the command line's or the stored campaign's), for "auto" what
    the profile implies (simulator episodes where the vehicle class has a simulator), else a flown local prior."""
    return resolve(command_line={} if cfg.prior == "auto" else {"prior": cfg.prior},
                   profile={"prior": "sim"} if profile is not None and profile.name in SIM_PRIOR_PROFILES else {},
                   default={"prior": "local"})["prior"]


def prior_size(cfg: CampaignConfig, kind: str) -> int:
    """Points of a ``kind`` prior: ``cfg.n_prior``, or (0) the kind's :data:`PRIOR_SIZES` default (0 for none)."""
    return resolve(command_line={"n_prior": cfg.n_prior} if cfg.n_prior else {},
                   default={"n_prior": PRIOR_SIZES.get(kind, 0)})["n_prior"]


#: Settings older campaigns stored that no longer exist, read past: ``widen`` (a stage after the search that moved
#: the box's bounds; the search box now grows within the search, :mod:`ksbo_mav.opt.acquisition.growing_box`).
RETIRED = ("widen",)


def stop_options(cfg: CampaignConfig, profile: Any) -> dict[str, Any]:
    """The optimiser's stopping rule (``early_stop``, :mod:`ksbo_mav.opt.methods.stopping`) for a settled ``cfg``:
    None when the setting ``early_stop`` is off; else the minimum from the settings, the patience and the
    threshold's ratio from the profile's ``[campaign]`` table."""
    if not cfg.early_stop:
        return {"early_stop": None}
    spec = profile.campaign_spec
    return {"early_stop": {"min_evals": int(cfg.min_trials or spec.stop_min_trials),
                           "patience": int(spec.stop_patience), "ratio": float(spec.stop_ratio)}}


#: ``ksbo-adaptive`` on a profile whose ``[safety] backup_covers_trials`` is true. ``backup_beta``: trials are
#: certified with β 0.5 instead of 5 while the abort budget lasts (BENCHMARKS.md: ArduCopter SITL -60 % with it,
#: +13 % without; on the planar task, whose tuned gains include the attitude loop, it crashes). ``tr_success``: the
#: trust region doubles after every new incumbent instead of every second one, so a search that keeps improving
#: reaches its box's edge (and the box grows) within the handful of trials one pack allows
#: (benchmarks/notes/smooth-gains.md).
COVERED_TRIALS = {"backup_beta": 0.5, "tr_success": 1}


def profile_defaults(method: str, profile: Any) -> dict[str, Any]:
    """Optimiser options a vehicle profile implies for ``method``: :data:`COVERED_TRIALS` for ``ksbo-adaptive``
    when the profile declares that the backup covers its trials (:class:`ksbo_mav.profile_sections.SafetyLimits`),
    else nothing."""
    if method == "ksbo-adaptive" and profile is not None and profile.safety.backup_covers_trials:
        return dict(COVERED_TRIALS)
    return {}


def optimizer_options(prior_kind: str, user: dict[str, Any], method: str = "", profile: Any = None
                      ) -> dict[str, Any]:
    """Optimiser keyword options of a tuning campaign, by :func:`resolve`: the user's ``user`` (command line or
    stored campaign) over the
    ``profile``'s for ``method`` (:func:`profile_defaults`) over the campaign's defaults.

    Every mission score here is bounded above by 1 (P(a) <= 1; 3-D: 1 - RMS / (2 RMS_baseline)), which is also
    the prior scale of P the benchmark campaign uses; the generic default (2 |P(a0)|) is far too tight. A simulator
    prior (``prior_kind == "sim"``) on the planar task is a dense cloud around the baseline of the same task: its
    good points are a fair head start, so candidates may grow around any of them (``explore_from="all"``); a
    copter's simulator prior (another model of the vehicle class), a flown or no prior keep the library default,
    growth from the baseline gains.
    """
    base: dict[str, Any] = {"signal_std": 1.0, "y_max": 1.0}
    if prior_kind == "sim" and (profile is None or profile.name == "sim-planar"):
        base["explore_from"] = "all"
    return resolve(command_line=user, profile=profile_defaults(method, profile), default=base)
