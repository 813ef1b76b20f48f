"""A campaign's settings: one typed, validated object, checked before anything connects or is written, and
:func:`resolve`, the one place that decides which value a setting takes when several places give one."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, replace
from typing import Any

from ksbo_mav.errors import InputError

PRIOR_KINDS = ("auto", "sim", "local", "none")
#: Default prior sizes: simulator episodes (computed, free) and flown local prior trials.
PRIOR_SIZES = {"sim": 36, "local": 8}
END_MODES = ("land", "hold")
#: Settings that may differ on ``--resume`` (they do not change what the optimiser has seen).
RESUMABLE = ("dir", "accept", "end", "sysid", "compid")


@dataclass
class CampaignConfig:
    """What ``ksbo-mav tune`` was asked to do. :meth:`validate` checks every field once."""

    dir: str
    profile: str | None = None
    method: str = "ksbo-adaptive"  # a vehicle has a monitor: aborts are censored, capped and re-flown around
    budget: int | None = None  # None: the profile's [campaign] budget (30 unless it says; the copters' 10)
    seed: int = 0
    prior: str = "auto"  # "sim", "local", "none", "auto" (sim for the built-in planar vehicle, else local)
    n_prior: int = 0  # 0 = default for the prior kind
    confirm: int = 1
    widen: bool = False  # extend a search-box bound the recommendation ends on (ksbo_mav.campaign.widen)
    warm_start: str | None = None  # a finished campaign's directory to start from (ksbo_mav.campaign.warm_start)
    baseline_every: int = 7  # re-fly the baseline after this many optimiser trials, drift test (0: never)
    on_drift: str = "stop"  # when the drift test fires: "stop" (land, resumable) or "continue" (corrected scores)
    rate_hz: int | None = None  # mission rate (setpoints and telemetry); None: the profile's, lowered by the link check
    accept: bool = False
    end: str = "land"  # "land" or "hold"
    settle_s: float = 1.0
    sysid: int | None = None  # our own MAVLink ids (None: the link's defaults)
    compid: int | None = None
    safety: dict[str, float] = field(default_factory=dict)
    options: dict[str, Any] = field(default_factory=dict)

    def validate(self) -> "CampaignConfig":
        """InputError naming the bad setting; also loads the profile (if named) and checks the optimiser options."""
        from ksbo_mav.opt import METHODS
        from ksbo_mav.opt.options import options_for
        from ksbo_mav.profiles import load_profile

        if self.method not in METHODS:
            raise InputError(f"unknown method {self.method!r}; choose one of {', '.join(METHODS)}")
        if self.on_drift not in ("stop", "continue"):
            raise InputError(f"on_drift must be stop or continue, got {self.on_drift!r}")
        for name, lo in (("budget", 1), ("confirm", 0), ("n_prior", 0), ("baseline_every", 0)):
            v = getattr(self, name)
            if name == "budget" and v is None:
                continue
            if isinstance(v, bool) or not isinstance(v, int) or v < lo:
                raise InputError(f"{name} must be an integer >= {lo}, got {v!r}")
        if self.prior not in PRIOR_KINDS:
            raise InputError(f"unknown prior {self.prior!r}; choose {', '.join(PRIOR_KINDS)}")
        if not isinstance(self.widen, bool):
            raise InputError(f"widen must be true or false, got {self.widen!r}")
        if self.warm_start is not None:
            from ksbo_mav.campaign.layout import CampaignDir

            CampaignDir.at(self.warm_start).read_result()  # InputError unless a finished campaign
            if self.budget is not None and self.budget < 2:
                raise InputError("a warm start needs --budget 2 or more (the baseline and the earlier recommendation)")
        if self.end not in END_MODES:
            raise InputError(f"--end must be land or hold, got {self.end!r}")
        for name in ("sysid", "compid"):
            v = getattr(self, name)
            if v is not None and not 1 <= v <= 255:
                raise InputError(f"--{name} must be in 1..255, got {v}")
        if self.rate_hz is not None and (isinstance(self.rate_hz, bool) or self.rate_hz not in (50, 25, 20, 10)):
            raise InputError(f"--rate must be 50, 25, 20 or 10 (Hz), got {self.rate_hz!r}")
        if not self.settle_s >= 0:
            raise InputError(f"settle_s must be >= 0, got {self.settle_s}")
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


def with_profile_budget(cfg: CampaignConfig, profile: Any) -> CampaignConfig:
    """``cfg`` with its budget settled: the command line's (or the stored campaign's), else the profile's."""
    if cfg.budget is not None:
        return cfg
    return replace(cfg, budget=int(profile.campaign_spec.budget))


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


#: ``backup_beta`` of ``ksbo-adaptive`` on a profile whose ``[safety] backup_covers_trials`` is true: trials are
#: certified with β 0.5 instead of 5 while the abort budget lasts (BENCHMARKS.md: ArduCopter SITL -60 % with it,
#: +13 % without; on the planar task, whose tuned gains include the attitude loop, it crashes).
BACKUP_BETA = 0.5


def profile_defaults(method: str, profile: Any) -> dict[str, Any]:
    """Optimiser options a vehicle profile implies for ``method``: ``backup_beta`` (:data:`BACKUP_BETA`) for
    ``ksbo-adaptive`` when the profile declares that the backup covers its trials
    (:class:`ksbo_mav.profile_sections.SafetyLimits`), else nothing."""
    if method == "ksbo-adaptive" and profile is not None and profile.safety.backup_covers_trials:
        return {"backup_beta": BACKUP_BETA}
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
