"""Typed tables of a vehicle profile (``[trust_region]``, ``[safety]``, ``[mission]``, ``[score]``).

Each table is a frozen dataclass whose fields are exactly the keys a profile may set: :func:`section_from_table`
refuses any other key with an :class:`InputError` naming the key and the file, and converts the values to the
fields' types. To add a key, add a field (with its default) to the dataclass. Re-exported by
:mod:`ksbo_mav.profiles`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any

from ksbo_mav.errors import InputError


#: ``[vehicle]`` keys: ``autopilot`` is the stack the vehicle must run (``ksbo_mav.mav.stacks``), ``frame`` the
#: motion model (``planar-xz``: the built-in planar simulator, which ``evaluate``/``prior`` fly in process).
VEHICLE_KEYS = ("name", "autopilot", "description", "frame")
FRAMES = ("planar-xz", "quad-3d")
#: Optional keys of a ``[[gains]]`` row besides the GainSpec fields; any other key must be a number present in
#: every row (a named preset such as ``scg``).
GAIN_EXTRA_KEYS = ("legacy_name", "legacy_scale", "canonical")
MISSION_TYPES = ("figure8-xz", "figure8-ne")


def _positive(obj: Any, *names: str) -> None:
    for n in names:
        v = getattr(obj, n)
        if v is not None and not v > 0:
            raise InputError(f"{n} must be positive, got {v!r}")


@dataclass(frozen=True)
class SafetyLimits:
    """``[safety]``: abort thresholds of a flight (x north, y east, z height above home, up).

    ``backup_covers_trials`` declares that a bad trial is slow enough for the monitor and the restored baseline
    gains (the backup) to catch: true when every tuned gain is an outer (position/velocity) loop whose output the
    autopilot clips to its lean-angle limit (ANGLE_MAX, MPC_TILTMAX_AIR) and the attitude loops are untouched.
    ``ksbo-adaptive`` then may fly gains outside the certified set while its abort budget lasts (option
    ``backup_beta``) and its trust region may double after every new incumbent (``tr_success``;
    :data:`ksbo_mav.campaign.config.COVERED_TRIALS`). False (the default) when the tuned gains
    include an attitude loop or nothing bounds the tilt: the planar task's bad gains flip the vehicle in 0.2 s.

    ``brake_accel_mps2`` (optional) checks the box at the point where the vehicle would stop braking at that
    deceleration, ``p + v·|v| / (2 a)`` per axis, so a vehicle racing towards the fence trips while there is room
    to stop; without it the box is checked at the position.
    """

    x_max_m: float = 2.0
    y_max_m: float = math.inf
    z_min_m: float = -0.05
    z_max_m: float = 2.0
    tilt_max_deg: float = 85.0
    tracking_error_max_m: float = 1.0
    heartbeat_timeout_s: float = 3.0
    backup_covers_trials: bool = False
    brake_accel_mps2: float | None = None

    def __post_init__(self) -> None:
        _positive(self, "x_max_m", "y_max_m", "tilt_max_deg", "tracking_error_max_m", "heartbeat_timeout_s",
                  "brake_accel_mps2")
        if not self.z_min_m < self.z_max_m:
            raise InputError(f"z_min_m {self.z_min_m:g} must be below z_max_m {self.z_max_m:g}")


@dataclass(frozen=True)
class TrustRegion:
    """``[trust_region]``: the campaign's first search box around the baseline: each gain at most
    ``max_step_fraction`` of its box width from the baseline, and within [baseline / max_ratio, baseline * max_ratio]
    when ``max_ratio`` is set.

    With ``grow`` (the default) the search box grows from there towards the profile's box (the autopilot's documented
    ranges) where the optimiser's incumbent sits on an edge, by half the first box's width per move
    (:mod:`ksbo_mav.opt.acquisition.growing_box`); every trial stays certified (LCB >= 0) and watched by the monitor.
    ``grow = false`` keeps the first box as the hard limit of every trial."""

    max_step_fraction: float = 1.0
    max_ratio: float | None = None
    grow: bool = True

    def __post_init__(self) -> None:
        if not 0 < self.max_step_fraction <= 1:
            raise InputError(f"max_step_fraction must be in (0, 1], got {self.max_step_fraction:g}")
        if self.max_ratio is not None and not self.max_ratio > 1:
            raise InputError(f"max_ratio must be > 1, got {self.max_ratio:g}")


@dataclass(frozen=True)
class MissionSpec:
    """``[mission]``: the figure-8 flown in every trial (``figure8-xz``: planar x-z; ``figure8-ne``: horizontal,
    north = scale_m sin wt, east = scale_east_m sin 2wt at center_up_m). ``lead_in_s`` (figure8-ne only) starts the
    pattern from rest over that many seconds (:mod:`ksbo_task.lead_in`) instead of with a velocity step.
    ``start_speed_mps`` (figure8-xz only) starts each trial moving: the vehicle passes the figure-8 start at a random
    velocity of up to that speed, as the paper's task starts its episodes (:mod:`ksbo_mav.mav.approach`); 0 starts
    from hover."""

    type: str = "figure8-xz"
    scale_m: float = 0.75
    scale_east_m: float | None = None  # None: scale_m
    period_s: float = 6.0
    center_up_m: float = 1.0
    laps: int = 2
    rate_hz: int = 50
    lead_in_s: float = 0.0
    start_speed_mps: float = 0.0

    def __post_init__(self) -> None:
        if self.type not in MISSION_TYPES:
            raise InputError(f"type {self.type!r} unknown (known: {', '.join(MISSION_TYPES)})")
        _positive(self, "scale_m", "scale_east_m", "period_s", "laps", "rate_hz")
        if not 0 <= self.lead_in_s < self.period_s * (self.laps - 1):
            raise InputError(f"lead_in_s must be in [0, {self.period_s * (self.laps - 1):g}) s (before the scored "
                             f"last lap), got {self.lead_in_s:g}")
        if self.lead_in_s and self.type != "figure8-ne":
            raise InputError("lead_in_s applies to figure8-ne missions only (figure8-xz is the paper's task, "
                             "which starts from a random initial velocity)")
        if not 0 <= self.start_speed_mps <= 3.0:
            raise InputError(f"start_speed_mps must be in [0, 3] m/s, got {self.start_speed_mps:g}")
        if self.start_speed_mps and self.type != "figure8-xz":
            raise InputError("start_speed_mps applies to figure8-xz missions only (the planar task's random "
                             "initial velocity; figure8-ne missions start from rest with lead_in_s)")
        if 1000 % self.rate_hz:
            raise InputError(f"rate_hz {self.rate_hz} must divide 1000")

    @property
    def scale_east(self) -> float:
        return self.scale_m if self.scale_east_m is None else self.scale_east_m


@dataclass(frozen=True)
class ScoreSpec:
    """``[score]``: overrides of the trial score. Unset keys (None) keep the scorer's defaults.

    Planar task (``ksbo_mav.scoring.ScoreConfig``): ``Q`` (6 state weights), ``R`` (2 input weights), ``u_ref``,
    ``j_hi``, ``lam``, ``floor``. 3-D copters (``ksbo_mav.mav.mission.Mission.score``):
    ``P = 1 - RMS / (unsafe_rms_ratio * RMS_ref)`` with RMS_ref the campaign's baseline flight (or ``rms_ref_m``
    when set: a fixed reference), so the baseline scores ``1 - 1/unsafe_rms_ratio`` and P < 0 means tracking more
    than ``unsafe_rms_ratio`` times worse than the baseline. ``smooth_weight`` (w, default 0: off) adds the
    smoothness term, ``P = 1 - (RMS / RMS_ref + w max(0, rough - rough_ref - b r) / r) / unsafe_rms_ratio``,
    ``r = max(rough_ref, 1)``, with rough the lap's body-rate roughness (deg/s) above ``rough_cutoff_hz``, rough_ref
    the baseline flight's and b ``rough_band`` (default 0: the measure's own scatter, a fraction of r;
    :mod:`ksbo_mav.smoothness`). New score keys are new fields here.
    """

    Q: tuple[float, ...] | None = None
    R: tuple[float, ...] | None = None
    u_ref: float | None = None
    j_hi: float | None = None
    lam: float | None = None
    floor: float | None = None
    unsafe_rms_ratio: float | None = None
    rms_ref_m: float | None = None
    smooth_weight: float | None = None
    rough_cutoff_hz: float | None = None
    rough_band: float | None = None

    def __post_init__(self) -> None:
        if self.Q is not None and len(self.Q) != 6 or self.R is not None and len(self.R) != 2:
            raise InputError("Q needs 6 diagonal weights and R needs 2")
        _positive(self, "j_hi", "rms_ref_m", "rough_cutoff_hz")
        if self.smooth_weight is not None and not self.smooth_weight >= 0:
            raise InputError(f"smooth_weight must be >= 0 (0: tracking alone), got {self.smooth_weight!r}")
        if self.rough_band is not None and not 0 <= self.rough_band < 1:
            raise InputError(f"rough_band must be in [0, 1) (a fraction of the baseline's roughness), "
                             f"got {self.rough_band!r}")
        if self.unsafe_rms_ratio is not None and not self.unsafe_rms_ratio > 1.0:
            raise InputError(f"unsafe_rms_ratio must be > 1 (the baseline must score safe), "
                             f"got {self.unsafe_rms_ratio}")

    def given(self) -> dict[str, Any]:
        """The keys the profile sets (lists as tuples)."""
        return {f.name: getattr(self, f.name) for f in fields(self) if getattr(self, f.name) is not None}


@dataclass(frozen=True)
class CampaignSpec:
    """``[campaign]``: defaults of ``ksbo-mav tune`` for this vehicle class (the command line overrides them).
    ``budget``: optimiser trials including the baseline; a copter's profile sets what one battery flies.
    ``early_stop``: end the search before the budget once the next flight's expected gain stays below the re-flight
    noise (times ``stop_ratio``) for ``stop_patience`` trials in a row, after ``stop_min_trials`` trials
    (:mod:`ksbo_mav.opt.methods.stopping`). ``trial_step``: every trial flies a position-only step after its
    figure-8 and aborts, as unsafe, when it leans past the tilt limit less ``trial_step_tilt_margin_deg``
    (:mod:`ksbo_mav.mav.trial_step`)."""

    budget: int = 30
    early_stop: bool = False
    stop_min_trials: int = 4
    stop_patience: int = 1
    stop_ratio: float = 1.0
    trial_step: bool = False
    trial_step_tilt_margin_deg: float = 0.0

    def __post_init__(self) -> None:
        _positive(self, "budget", "stop_min_trials", "stop_patience", "stop_ratio")
        if not 0 <= self.trial_step_tilt_margin_deg < 30:
            raise InputError(f"trial_step_tilt_margin_deg must be in [0, 30) deg, got "
                             f"{self.trial_step_tilt_margin_deg:g}")


#: Manoeuvres a validation may fly (:mod:`ksbo_mav.mav.validation`).
MANOEUVRES = ("steps", "hold", "auto_mission")


@dataclass(frozen=True)
class ValidationSpec:
    """``[validation]``: the flights after a tune that compare the baseline and the recommended gains on what
    pilots fly (:mod:`ksbo_mav.campaign.validation`). ``manoeuvres``: the kinds flown, in order, comma-separated
    (empty: no validation, e.g. the planar task, which has no autopilot navigation); ``repeats`` flights of each
    gain set per manoeuvre in ``--validation quick`` (the default), ``full_repeats`` in ``full``; ``candidates``:
    further gain sets from the campaign's best trials flown when the recommendation is worse somewhere (``full``;
    ``quick`` flies one at most). The sub-tables ``[validation.steps]``, ``[validation.hold]`` and
    ``[validation.auto_mission]`` size each manoeuvre (their keys: :class:`ksbo_mav.mav.validation.ManoeuvreSpec`)."""

    manoeuvres: str = ""
    repeats: int = 2
    full_repeats: int = 3
    candidates: int = 2
    steps: dict[str, Any] = field(default_factory=dict)
    hold: dict[str, Any] = field(default_factory=dict)
    auto_mission: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        odd = [k for k in self.kinds if k not in MANOEUVRES]
        if odd:
            raise InputError(f"manoeuvres: {odd[0]!r} unknown (known: {', '.join(MANOEUVRES)})")
        if self.repeats < 2 or self.full_repeats < 2:
            raise InputError("repeats and full_repeats must be at least 2 (two flights of each gain set measure "
                             "their spread)")
        if self.candidates < 0:
            raise InputError(f"candidates must be 0 or more, got {self.candidates}")

    @property
    def kinds(self) -> tuple[str, ...]:
        return tuple(k.strip() for k in self.manoeuvres.split(",") if k.strip())

    def sizes(self, kind: str) -> dict[str, Any]:
        """The sub-table sizing manoeuvre ``kind`` (empty: its defaults)."""
        return dict(getattr(self, kind))


#: Tables of a profile besides [vehicle] and [[gains]], by table name.
SECTIONS: dict[str, type] = {"trust_region": TrustRegion, "safety": SafetyLimits, "mission": MissionSpec,
                             "score": ScoreSpec, "campaign": CampaignSpec, "validation": ValidationSpec}


def section_from_table(cls: type, table: dict[str, Any], name: str, where: str) -> Any:
    """Check a TOML table against ``cls``'s fields (the allowed keys), convert each value to its field's type."""
    known = [f.name for f in fields(cls)]
    unknown = [k for k in table if k not in known]
    if unknown:
        raise InputError(f"profile {where}: unknown key {unknown[0]!r} in [{name}] (known: {', '.join(known)})")
    kinds = {f.name: str(f.type).split(" |")[0] for f in fields(cls)}
    values = {}
    for key, v in table.items():
        try:
            values[key] = _value(kinds[key], v)
        except TypeError as exc:
            raise InputError(f"profile {where}: [{name}] {key} = {v!r}: expected {exc}") from None
    try:
        return cls(**values)
    except InputError as exc:
        raise InputError(f"profile {where}: [{name}] {exc}") from None


def _value(kind: str, v: Any) -> Any:
    """A TOML value as a field of type ``kind`` (float, int, str, bool or tuple[float, ...]); TypeError if not."""
    number = isinstance(v, (int, float)) and not isinstance(v, bool)
    if kind == "float" and number and not math.isnan(v):
        return float(v)
    if kind == "int" and number and isinstance(v, int) or kind == "str" and isinstance(v, str):
        return v
    if kind == "bool" and isinstance(v, bool):
        return v
    if kind.startswith("tuple") and isinstance(v, list):
        return tuple(_value("float", x) for x in v)
    if kind.startswith("dict") and isinstance(v, dict):
        return dict(v)
    raise TypeError({"float": "a number", "int": "a whole number", "str": "a string",
                     "bool": "true or false"}.get(kind, "a table" if kind.startswith("dict") else "a list of numbers"))
