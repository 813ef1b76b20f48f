"""JSON for results and records: numpy scalars/arrays become plain values, NaN/inf become null (valid JSON); and
the durable write every record on disk goes through (a leaf module: the MAVLink client and the campaign both use it).
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
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


def fsync_write(path: Path, text: str) -> None:
    """Atomically replace ``path`` with ``text`` and make it durable: a temporary file, fsynced and renamed, then
    the directory fsynced, so after a crash of the tool or the machine ``path`` holds the old text or the new."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w") as fh:
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    fsync_dir(path.parent)


def fsync_dir(path: Path) -> None:
    """Make a directory's entries (a rename into it) durable; a file system that cannot is left as it is."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)
