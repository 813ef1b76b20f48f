"""What ``fun`` may return to :func:`ksbo_mav.optimize`: a plain float, or an :class:`Evaluation` with an outcome.

* ``float`` — a completed trial with that value (the paper's strict mode: a value below ``p_min`` is unsafe).
* ``Evaluation(value, Outcome.COMPLETE)`` — the same, explicitly.
* ``Evaluation(value_or_None, Outcome.ABORTED)`` — the monitor stopped the trial and the backup recovered. The
  value (if any, e.g. the paper's P of the part flown) is kept for the record, but the optimiser treats the trial
  as *censored*: it only learns "this point aborts", never a made-up P value.
* ``Evaluation(value_or_None, Outcome.CRASHED)`` — the backup did not recover (counted separately).

Anything else (None, NaN, an array of several values, a string) is a bug in ``fun`` and raises
:class:`ksbo_mav.errors.ObjectiveError` naming the evaluation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np

from ksbo_mav.errors import ObjectiveError

__all__ = ["Evaluation", "Outcome", "as_evaluation"]


class Outcome(str, Enum):
    """How a trial ended. ``str`` valued, so ``Outcome.ABORTED == "aborted"`` and it serialises as text; a
    simulator's or vehicle layer's own outcome enum with the same values converts through :meth:`parse`."""

    COMPLETE = "complete"
    ABORTED = "aborted"
    CRASHED = "crashed"

    @classmethod
    def parse(cls, value: "Enum | str") -> "Outcome":
        """``Outcome`` from itself, another enum with the same values, or text ("completed" and "ok" are
        accepted for "complete")."""
        if isinstance(value, Outcome):
            return value
        v = str(value.value if isinstance(value, Enum) else value).strip().lower()
        if v in ("completed", "ok"):
            return cls.COMPLETE
        return cls(v)


@dataclass(frozen=True)
class Evaluation:
    """One trial's result: ``value`` (None when unknown) and how the trial ended."""

    value: float | None
    outcome: Outcome = Outcome.COMPLETE

    @property
    def censored(self) -> bool:
        """True for aborted and crashed trials: their value is not an observation of the objective."""
        return self.outcome is not Outcome.COMPLETE


def as_evaluation(raw: Any, index: int, x: np.ndarray) -> Evaluation:
    """Normalise what ``fun`` returned at evaluation ``index`` (point ``x`` (d,), physical units)."""
    where = f"evaluation {index} (x = {np.array2string(np.asarray(x), precision=4)})"
    if isinstance(raw, Evaluation):
        try:
            outcome = Outcome.parse(raw.outcome)
        except ValueError:
            raise ObjectiveError(f"fun returned an unknown outcome {raw.outcome!r} at {where}") from None
        value = raw.value
        if value is not None:
            value = _number(value, where)
        elif outcome is Outcome.COMPLETE:
            raise ObjectiveError(f"fun returned a complete Evaluation without a value at {where}")
        return Evaluation(value, outcome)
    return Evaluation(_number(raw, where), Outcome.COMPLETE)


def _number(raw: Any, where: str) -> float:
    if raw is None:
        raise ObjectiveError(f"fun returned None at {where}; return a float (or an Evaluation)")
    if isinstance(raw, (bool, str, bytes)):
        raise ObjectiveError(f"fun returned {type(raw).__name__} {raw!r} at {where}; return a float")
    arr = np.asarray(raw)
    if arr.size != 1:
        raise ObjectiveError(f"fun returned an array of shape {arr.shape} at {where}; return one float")
    try:
        value = float(arr.reshape(()))
    except (TypeError, ValueError):
        raise ObjectiveError(f"fun returned a non-numeric {type(raw).__name__} at {where}") from None
    if not math.isfinite(value):
        raise ObjectiveError(f"fun returned {value} at {where}; report a failed trial as "
                             "Evaluation(None, Outcome.ABORTED or CRASHED) instead")
    return value
