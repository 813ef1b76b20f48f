"""A sweep is a file: ``benchmarks/sweeps/NAME.toml`` declares what a benchmark flies, and its cells are the
product of the declared values.

    [sweep]
    title = "Adaptive safe BO over the plant suite, with the monitor"
    kind = "plant"                      # the cell kind (ksbo_bench.kinds): what one cell runs
    # store = "benchmarks/store/NAME"   # where its records go (default: benchmarks/store/<file stem>)

    [fixed]                             # values every cell has
    mode = "monitor"
    budget = 100

    [grid]                              # one cell per combination; a list, or "0-9" for integers
    plant = ["nominal", "mass+30"]
    method = ["ksbo", "ksbo-adaptive"]
    seed = "0-9"

``archive = true`` in [sweep]: a store of records kept for their history (superseded defaults, one-off
experiments), shown on its page, with no cell to run.

``[[grid]]`` (an array of tables) declares a union of such products, for settings that differ in more than one
value (LineBO's 200 flights where the others fly 150). A cell's key is its declared values (fixed and grid): two
cells with the same key are the same cell, and a record whose key is in the store is not run again.
"""

from __future__ import annotations

import itertools
import json
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ksbo_bench.cell_errors import SweepError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
SWEEPS = ROOT / "benchmarks" / "sweeps"
STORES = ROOT / "benchmarks" / "store"


def parse_ints(text: str) -> list[int]:
    """``"0-9"``, ``"0,3,5-7"`` -> the integers, in order."""
    out: list[int] = []
    try:
        for part in str(text).split(","):
            a, _, b = part.strip().partition("-")
            out += list(range(int(a), int(b) + 1)) if b else [int(a)]
    except ValueError:
        raise SweepError(f"not a list of integers like 0-9 or 0,3,5-7: {text!r}") from None
    return out


def key_id(key: dict[str, Any]) -> str:
    """The key as one canonical string (sorted JSON): what the store compares."""
    return json.dumps(key, sort_keys=True, separators=(",", ":"))


@dataclass(frozen=True)
class Cell:
    """One campaign or one evaluation: its kind and its declared values."""

    sweep: str
    kind: str
    key: dict[str, Any]
    inputs: dict[str, Any] = field(default_factory=dict, compare=False)  # resolved by the driver, not the key

    @property
    def id(self) -> str:
        return key_id(self.key)

    def label(self, width: int = 0, names: "set[str] | None" = None) -> str:
        """The cell's values (only ``names``, if given), for a progress line (``plant=nominal seed=3``)."""
        return " ".join(f"{k}={v}" for k, v in self.key.items()
                        if (names is None or k in names) and not isinstance(v, (dict, list)))[:width or None]


@dataclass
class Sweep:
    name: str
    path: Path
    kind: str
    title: str
    fixed: dict[str, Any]
    grids: list[dict[str, list[Any]]]
    store: Path
    report: dict[str, Any] = field(default_factory=dict)
    description: str = ""
    archive: bool = False  # records kept for their history: no cell to run


    def cells(self, seeds: list[int] | None = None) -> list[Cell]:
        """Every cell, in declaration order (the first axis slowest); ``seeds`` replaces the seed axis."""
        out: list[Cell] = []
        seen: set[str] = set()
        for grid in [] if self.archive else self.grids:
            axes = dict(grid)
            if seeds is not None:
                if "seed" not in axes and "seed" not in self.fixed:
                    raise SweepError(f"{self.name}: --seeds given but the sweep declares no seed")
                axes["seed"] = list(seeds)
            fixed = {k: v for k, v in self.fixed.items() if k not in axes}
            names = list(axes)
            for combo in itertools.product(*(axes[n] for n in names)):
                cell = Cell(self.name, self.kind, {**fixed, **dict(zip(names, combo))})
                if cell.id not in seen:
                    seen.add(cell.id)
                    out.append(cell)
        return out


def varying(cells: list[Cell]) -> set[str]:
    """The key names whose values differ among ``cells`` (what tells one cell from another)."""
    vals: dict[str, set[str]] = {}
    for c in cells:
        for k, v in c.key.items():
            vals.setdefault(k, set()).add(json.dumps(v, sort_keys=True))
    return {k for k, v in vals.items() if len(v) > 1} or set(vals)


def _axis(name: str, values: Any, where: Path) -> list[Any]:
    if name == "seed" and isinstance(values, (str, int)):
        return parse_ints(str(values))
    if isinstance(values, str) and values[:1].isdigit() and "-" in values:
        return parse_ints(values)
    if not isinstance(values, list) or not values:
        raise SweepError(f"{where}: grid value {name!r} must be a non-empty list (or a range like \"0-9\")")
    return values


def load(path: str | Path) -> Sweep:
    """The sweep declared in ``path`` (a file, or the name of one in benchmarks/sweeps/)."""
    from ksbo_bench.kinds import KINDS

    p = Path(path)
    if not p.suffix and not p.exists():
        p = SWEEPS / f"{p}.toml"
    try:
        data = tomllib.loads(p.read_text())
    except FileNotFoundError:
        raise SweepError(f"no sweep file {p} (the sweeps: `ksbo-bench list`)") from None
    except tomllib.TOMLDecodeError as e:
        raise SweepError(f"{p}: not TOML ({e})") from None
    head = data.get("sweep", {})
    kind = head.get("kind")
    if kind not in KINDS:
        raise SweepError(f"{p}: [sweep] kind {kind!r} is not one of {', '.join(sorted(KINDS))}")
    raw = data.get("grid", {})
    grids = raw if isinstance(raw, list) else [raw]
    grids = [{k: _axis(k, v, p) for k, v in g.items()} for g in grids] or [{}]
    fixed = data.get("fixed", {})
    name = head.get("name", p.stem)
    store = Path(head["store"]) if "store" in head else STORES / name
    sweep = Sweep(name=name, path=p, kind=kind, title=head.get("title", name), fixed=fixed, grids=grids,
                  store=store if store.is_absolute() else ROOT / store, report=data.get("report", {}),
                  description=head.get("description", ""), archive=bool(head.get("archive", False)))
    for cell in sweep.cells()[:1]:
        KINDS[kind].check(cell.key)  # a missing or unknown value is said now, not after an hour of cells
    return sweep


def all_sweeps() -> list[Sweep]:
    return [load(p) for p in sorted(SWEEPS.glob("*.toml"))]
