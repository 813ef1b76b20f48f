"""A cell's working folder (a campaign, its logs, the SITL's): removed after a cell that ended normally, kept and
named otherwise (a few MB each: 1,000 cells would fill a node's /tmp)."""

from __future__ import annotations

import shutil
import sys
import tempfile
from pathlib import Path
from typing import Any, Callable


def in_work_folder(kind: str, fn: Callable[[dict, dict, Path], dict], key: dict[str, Any],
                   inputs: dict[str, Any] | None) -> dict[str, Any]:
    """``fn(key, inputs, folder)`` in a fresh folder: removed when it returns a record part whose status is not
    "failed" and the key does not ask to ``keep`` it; kept and named in ``result.kept`` otherwise, and named on
    stderr when ``fn`` raised."""
    work = Path(tempfile.mkdtemp(prefix=f"ksbo-bench-{kind}-"))
    try:
        out = fn(key, inputs or {}, work)
    except BaseException:
        print(f"{kind} cell: its folder is kept: {work}", file=sys.stderr)
        raise
    if out.get("status", "ok") != "failed" and not key.get("keep"):
        shutil.rmtree(work, ignore_errors=True)
    else:
        out.setdefault("result", {})["kept"] = str(work)
    return out
