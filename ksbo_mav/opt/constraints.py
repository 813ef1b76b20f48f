"""Declared constraints of the optimiser's options (scikit-learn's ``_parameter_constraints`` is the model): each
option names what it accepts once, and one function checks a value against it and says what was wrong."""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Integral, Real
from typing import Any


def _is_number(v: Any) -> bool:
    return isinstance(v, Real) and not isinstance(v, bool)


@dataclass(frozen=True)
class Interval:
    """A number (``integer``: a whole one) in [low, high]; ``open_low``/``open_high`` exclude that end; ``none``:
    null is allowed too (its meaning is the option's documentation)."""

    low: float | None = None
    high: float | None = None
    integer: bool = False
    open_low: bool = False
    open_high: bool = False
    none: bool = False

    def accepts(self, v: Any) -> bool:
        if v is None:
            return self.none
        if not _is_number(v) or not math.isfinite(float(v)):
            return False
        if self.integer and not (isinstance(v, Integral) or float(v).is_integer()):
            return False
        lo_ok = self.low is None or (v > self.low if self.open_low else v >= self.low)
        hi_ok = self.high is None or (v < self.high if self.open_high else v <= self.high)
        return lo_ok and hi_ok

    def describe(self) -> str:
        what = "an integer" if self.integer else "a number"
        lo = "-inf" if self.low is None else f"{self.low:g}"
        hi = "inf" if self.high is None else f"{self.high:g}"
        left = "(" if self.open_low or self.low is None else "["
        right = ")" if self.open_high or self.high is None else "]"
        return f"{what} in {left}{lo}, {hi}{right}" + (" or null" if self.none else "")


@dataclass(frozen=True)
class Choice:
    """One of ``values``."""

    values: tuple[Any, ...]

    def accepts(self, v: Any) -> bool:
        return any(v is c or (type(v) is type(c) and v == c) for c in self.values)

    def describe(self) -> str:
        return "one of " + ", ".join(_show(c) for c in self.values)


@dataclass(frozen=True)
class Orders:
    """A non-empty list of distinct additive orders ≥ 1 (integers); ``none``: null too."""

    none: bool = True

    def accepts(self, v: Any) -> bool:
        if v is None:
            return self.none
        if not isinstance(v, (list, tuple)) or not v:
            return False
        return all(_is_number(r) and float(r).is_integer() and r >= 1 for r in v) and len(set(v)) == len(v)

    def describe(self) -> str:
        return "a list of distinct integers >= 1" + (" or null" if self.none else "")


BOOL = Choice((True, False))
Constraint = Interval | Choice | Orders


def _show(v: Any) -> str:
    return {True: "true", False: "false", None: "null"}.get(v, str(v)) if isinstance(v, (bool, type(None))) \
        else str(v)


def violation(name: str, value: Any, constraint: Constraint) -> str | None:
    """None if ``value`` satisfies ``constraint``, else one line naming the option, the value and what it accepts."""
    if constraint.accepts(value):
        return None
    return f"option {name}={_show(value) if isinstance(value, (bool, type(None))) else repr(value)} is not " \
           f"allowed: {name} must be {constraint.describe()}"
