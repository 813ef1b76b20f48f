"""JSON for results and records: numpy scalars/arrays become plain values, NaN/inf become null (valid JSON)."""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np


def jsonable(o: Any) -> Any:
    """A copy of ``o`` that :func:`json.dumps` accepts without ``NaN`` tokens: dict keys as str, tuples as lists,
    numpy scalars and arrays as Python values, non-finite floats as None."""
    if isinstance(o, dict):
        return {str(k): jsonable(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [jsonable(v) for v in o]
    if isinstance(o, np.ndarray):
        return jsonable(o.tolist())
    if isinstance(o, np.generic):
        return jsonable(o.item())
    if isinstance(o, float) and not math.isfinite(o):
        return None
    return o


def dumps(o: Any, indent: int | None = 2) -> str:
    """``json.dumps`` of :func:`jsonable` (o)."""
    return json.dumps(jsonable(o), indent=indent, allow_nan=False)
