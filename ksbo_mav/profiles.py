"""Vehicle profiles: which gains are tuned, their names on the vehicle, bounds, defaults, safety limits.

Profiles are TOML files in the ``ksbo_params`` data package (source directory ``params/``), found the same way
whether the package is installed editable or not; a path to any TOML file works too.

Every table is typed and checked when the file is read: ``[vehicle]`` (:data:`VEHICLE_KEYS`), ``[[gains]]``
(:class:`GainSpec`), ``[trust_region]`` (:class:`TrustRegion`), ``[safety]`` (:class:`SafetyLimits`),
``[mission]`` (:class:`MissionSpec`), ``[score]`` (:class:`ScoreSpec`) and ``[campaign]``
(:class:`CampaignSpec`). A key nothing reads is an
:class:`InputError` naming the key and the file (a typo in ``[safety]`` must not silently keep a default limit).
To add a key, add a field to the table's dataclass (:mod:`ksbo_mav.profile_sections`): its fields are the
allowed keys.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.profile_sections import (FRAMES, GAIN_EXTRA_KEYS, MISSION_TYPES, SECTIONS, VEHICLE_KEYS,  # noqa: F401
                                       CampaignSpec, MissionSpec, SafetyLimits, ScoreSpec, TrustRegion, ValidationSpec,
                                       section_from_table)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib


@dataclass(frozen=True)
class GainSpec:
    """One tuned gain: vehicle parameter name, short label, unit, search bounds and the safe default."""

    name: str
    label: str
    unit: str
    min: float
    max: float
    default: float
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Profile:
    """A vehicle profile. Arrays are in the order of ``gains``; *unit* coordinates map the box to [0, 1]^d."""

    name: str
    vehicle: dict[str, Any]
    gains: tuple[GainSpec, ...]
    sections: dict[str, Any]
    path: str
    safety: SafetyLimits = SafetyLimits()
    trust_region: TrustRegion = TrustRegion()
    mission_spec: MissionSpec = MissionSpec()
    score_spec: ScoreSpec = ScoreSpec()
    campaign_spec: CampaignSpec = CampaignSpec()
    validation_spec: ValidationSpec = ValidationSpec()

    @property
    def frame(self) -> str:
        return str(self.vehicle.get("frame", "planar-xz"))

    @property
    def names(self) -> list[str]:
        return [g.name for g in self.gains]

    @property
    def labels(self) -> list[str]:
        return [g.label for g in self.gains]

    @property
    def dim(self) -> int:
        return len(self.gains)

    @property
    def bounds(self) -> np.ndarray:
        """(d, 2) physical [min, max] of every gain."""
        return np.array([[g.min, g.max] for g in self.gains], dtype=float)

    @property
    def default(self) -> np.ndarray:
        """(d,) default (known-safe) gains."""
        return np.array([g.default for g in self.gains], dtype=float)

    def preset(self, key: str) -> np.ndarray:
        """(d,) gains of a named preset stored per gain (e.g. ``scg``), or ``default``."""
        if key == "default":
            return self.default
        missing = [g.name for g in self.gains if key not in g.extra]
        if missing:
            raise InputError(f"profile {self.name!r} has no preset {key!r}")
        return np.array([float(g.extra[key]) for g in self.gains])

    def to_unit(self, x: np.ndarray) -> np.ndarray:
        b = self.bounds
        return (np.asarray(x, dtype=float) - b[:, 0]) / (b[:, 1] - b[:, 0])

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        b = self.bounds
        return b[:, 0] + np.asarray(u, dtype=float) * (b[:, 1] - b[:, 0])

    def section(self, key: str) -> dict[str, Any]:
        """The keys a table of the file sets, as a dict (validated; defaults are on the typed attributes
        ``safety``, ``trust_region``, ``mission_spec``, ``score_spec``)."""
        return dict(self.sections.get(key, {}))

    def check_gains(self, x: np.ndarray, within_box: bool = True) -> np.ndarray:
        """Validate a (d,) or (n, d) gain array: shape, finiteness, range. Returns it as float.

        With ``within_box=False`` only the lower bounds are enforced (a simulator may fly gains above the
        search box; nothing may fly gains below it, e.g. negative PID gains).
        """
        try:
            arr = np.asarray(x, dtype=float)
        except (TypeError, ValueError) as exc:
            raise InputError(f"gains must be numbers: {exc}") from None
        if arr.shape[-1:] != (self.dim,) or arr.ndim > 2:
            raise InputError(f"expected {self.dim} gains ({', '.join(self.labels)}), got shape {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise InputError("gains must be finite (got NaN or infinity)")
        b = self.bounds
        out = (arr < b[:, 0]) | ((arr > b[:, 1]) if within_box else False)
        bad = np.any(out, axis=0) if arr.ndim == 2 else out
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            g = self.gains[i]
            if not within_box:
                raise InputError(f"gain {g.name} ({g.label}) below its minimum {g.min:g}")
            raise InputError(f"gain {g.name} ({g.label}) outside its range [{g.min:g}, {g.max:g}]")
        return arr


def available_profiles() -> list[str]:
    """Names of the profiles shipped with the package."""
    return sorted(p.name[:-5] for p in resources.files("ksbo_params").iterdir() if p.name.endswith(".toml"))


def load_profile(name_or_path: str | Path) -> Profile:
    """Load a shipped profile by name (``sim-planar``) or a TOML file by path.

    A file may start from another profile with a top-level ``extends = "NAME"`` (a shipped name, or a path
    relative to the file): its tables are taken key by key (nested ones too), the file's own keys win, and
    ``[[gains]]`` given in the file replace the base's whole list. So a profile for one airframe holds only what
    differs from the stock one."""
    data, where = _read(name_or_path, ())
    return _parse(data, where)


def _read(name_or_path: str | Path, chain: tuple[str, ...]) -> tuple[dict[str, Any], str]:
    """A profile's TOML with its ``extends`` chain merged in (base first), and where it was read from."""
    path = Path(name_or_path)
    if path.suffix == ".toml" and path.exists():
        text, where = path.read_text(), str(path)
    else:
        res = resources.files("ksbo_params").joinpath(f"{name_or_path}.toml")
        if not res.is_file():
            raise InputError(f"unknown profile {str(name_or_path)!r}; available: {', '.join(available_profiles())}")
        text, where = res.read_text(), str(res)
    if where in chain:
        raise InputError(f"profile {where}: extends itself (through {' -> '.join(chain)})")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"profile {where}: invalid TOML: {exc}") from None
    base_name = data.pop("extends", None)
    if base_name is None:
        return data, where
    if not isinstance(base_name, str) or not base_name:
        raise InputError(f"profile {where}: extends must be a profile name or a .toml path")
    if base_name.endswith(".toml") and not Path(base_name).is_absolute():
        base_name = str(Path(where).parent / base_name)
    base, _ = _read(base_name, (*chain, where))
    return _merged(base, data), where


def _merged(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    """``over`` laid on ``base``: tables merge key by key at every depth, anything else (lists included) replaces."""
    out = dict(base)
    for key, value in over.items():
        both = isinstance(value, dict) and isinstance(base.get(key), dict)
        out[key] = _merged(base[key], value) if both else value
    return out


def _parse(data: dict[str, Any], where: str) -> Profile:
    unknown = sorted(set(data) - {"vehicle", "gains", *SECTIONS})
    if unknown:
        raise InputError(f"profile {where}: unknown table [{unknown[0]}] "
                         f"(known: vehicle, gains, {', '.join(SECTIONS)})")
    vehicle = _table(data, "vehicle", where)
    rows = data.get("gains")
    if not vehicle.get("name") or not rows or not isinstance(rows, list):
        raise InputError(f"profile {where}: needs [vehicle] name and at least one [[gains]] table")
    _check_keys(vehicle, VEHICLE_KEYS, "[vehicle]", where)
    if vehicle.get("frame", "planar-xz") not in FRAMES:
        raise InputError(f"profile {where}: [vehicle] frame {vehicle['frame']!r} unknown (known: {', '.join(FRAMES)})")
    gains = tuple(_gain(row, where) for row in rows)
    presets = [{k for k in g.extra if k not in GAIN_EXTRA_KEYS} for g in gains]
    for g, keys in zip(gains, presets):
        odd = sorted(keys - set.intersection(*presets))
        if odd:
            raise InputError(f"profile {where}: gain {g.name}: unknown key {odd[0]!r} (a preset value must be "
                             f"given for every gain; other keys: {', '.join(GAIN_EXTRA_KEYS)})")
    typed = {name: section_from_table(cls, _table(data, name, where), name, where) for name, cls in SECTIONS.items()}
    sections = {k: v for k, v in data.items() if k not in {"vehicle", "gains"}}
    return Profile(name=str(vehicle["name"]), vehicle=vehicle, gains=gains, sections=sections, path=where,
                   safety=typed["safety"], trust_region=typed["trust_region"], mission_spec=typed["mission"],
                   score_spec=typed["score"], campaign_spec=typed["campaign"],
                   validation_spec=typed["validation"])


def _table(data: dict[str, Any], name: str, where: str) -> dict[str, Any]:
    t = data.get(name, {})
    if not isinstance(t, dict):
        raise InputError(f"profile {where}: {name} must be a table [{name}]")
    return t


def _check_keys(table: dict[str, Any], known: tuple[str, ...] | list[str], what: str, where: str) -> None:
    unknown = [k for k in table if k not in known]
    if unknown:
        raise InputError(f"profile {where}: unknown key {unknown[0]!r} in {what} (known: {', '.join(known)})")


def _gain(row: Any, where: str) -> GainSpec:
    if not isinstance(row, dict):
        raise InputError(f"profile {where}: every gains entry must be a [[gains]] table")
    base = {"name", "label", "unit", "min", "max", "default"}
    try:
        spec = GainSpec(name=str(row["name"]), label=str(row.get("label", row["name"])),
                        unit=str(row.get("unit", "")), min=float(row["min"]), max=float(row["max"]),
                        default=float(row["default"]), extra={k: v for k, v in row.items() if k not in base})
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"profile {where}: gain entry {row!r} is incomplete: {exc}") from None
    if not spec.min < spec.max or not spec.min <= spec.default <= spec.max:
        raise InputError(f"profile {where}: gain {spec.name} needs min < max and default inside")
    for k, v in spec.extra.items():
        if k not in GAIN_EXTRA_KEYS and (isinstance(v, bool) or not isinstance(v, (int, float))):
            raise InputError(f"profile {where}: gain {spec.name}: unknown key {k!r} "
                             f"(known: {', '.join([*sorted(base), *GAIN_EXTRA_KEYS])}, or a numeric preset)")
    return spec

