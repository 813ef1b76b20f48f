"""Vehicle profiles: which gains are tuned, their names on the vehicle, bounds, defaults, safety limits.

Profiles are TOML files in the ``ksbo_params`` data package (source directory ``params/``), found the same way
whether the package is installed editable or not; a path to any TOML file works too.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError

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
    """Load a shipped profile by name (``sim-planar``) or a TOML file by path."""
    text: str
    path = Path(name_or_path)
    if path.suffix == ".toml" and path.exists():
        text, where = path.read_text(), str(path)
    else:
        res = resources.files("ksbo_params").joinpath(f"{name_or_path}.toml")
        if not res.is_file():
            raise InputError(f"unknown profile {str(name_or_path)!r}; available: {', '.join(available_profiles())}")
        text, where = res.read_text(), str(res)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"profile {where}: invalid TOML: {exc}") from None
    return _parse(data, where)


def _parse(data: dict[str, Any], where: str) -> Profile:
    vehicle = data.get("vehicle", {})
    rows = data.get("gains")
    if not vehicle.get("name") or not rows:
        raise InputError(f"profile {where}: needs [vehicle] name and at least one [[gains]] table")
    gains = []
    for row in rows:
        try:
            spec = GainSpec(name=str(row["name"]), label=str(row.get("label", row["name"])),
                            unit=str(row.get("unit", "")), min=float(row["min"]), max=float(row["max"]),
                            default=float(row["default"]),
                            extra={k: v for k, v in row.items()
                                   if k not in {"name", "label", "unit", "min", "max", "default"}})
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"profile {where}: gain entry {row!r} is incomplete: {exc}") from None
        if not spec.min < spec.max or not spec.min <= spec.default <= spec.max:
            raise InputError(f"profile {where}: gain {spec.name} needs min < max and default inside")
        gains.append(spec)
    sections = {k: v for k, v in data.items() if k not in {"vehicle", "gains"}}
    return Profile(name=str(vehicle["name"]), vehicle=vehicle, gains=tuple(gains), sections=sections, path=where)
