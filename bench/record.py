"""One record schema for every cell of every sweep, written as one JSON line to the sweep's store.

    {"schema": 1, "sweep": "plants-monitor", "kind": "plant", "key": {...the cell's declared values...},
     "status": "ok",                          # ok, or "failed" (the cell ran and failed for the gains or itself)
     "flights": {"total": 100, ...},          # the campaign's flights, counted as the README counts them
     "safety": {"crashed": 0, "aborted": 2, "interrupted": 0, "unsafe": 1},
     "result": {...},                         # the kind's figures: the re-flown E[P] or RMS, the recommendation
     "timing": {"wall_s": 12.1, "load_1min": 0.4, ...},   # seconds and the machine's load at the end: never compared
     "run": {"code": "a229ed0", "dirty": false, "machine": "...", "node": "...", "executor": "local",
             "started": "2026-12-07T01:30:00Z", "attempts": 1}}

``comparable(record)`` is what two runs of the same cell must agree on (everything but timing and run).
"""

from __future__ import annotations

import datetime as dt
import functools
import os
import platform
import re
import socket
import subprocess
from pathlib import Path
from typing import Any

SCHEMA = 1
ROOT = Path(__file__).resolve().parents[1]
#: What differs between two runs of the same cell by nature: when, where, how long, by which code.
VOLATILE = ("timing", "run")


def comparable(rec: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in rec.items() if k not in VOLATILE}


@functools.lru_cache(maxsize=1)
def code_version() -> tuple[str, bool]:
    """(short commit, whether the work tree differs from it) of this checkout; ("unknown", False) outside git."""
    try:
        sha = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                             timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT,
                               capture_output=True, text=True, timeout=10).stdout.strip() != ""
        return sha or "unknown", dirty
    except (OSError, subprocess.SubprocessError):
        return "unknown", False


@functools.lru_cache(maxsize=1)
def machine() -> str:
    """One line: CPU model, cores, Python and numpy versions (the date is the record's ``started``)."""
    cpu = platform.processor() or "unknown CPU"
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, timeout=10).stdout
        m = re.search(r"Model name:\s*(.+)", out)
        cpu = m.group(1).strip() if m else cpu
    except (OSError, subprocess.SubprocessError):
        pass
    import numpy

    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, numpy {numpy.__version__}"


def now() -> str:
    return dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def make(cell, out: dict[str, Any], started: str, wall_s: float, executor: str, node: str = "",
         attempts: int = 1) -> dict[str, Any]:
    """The record of ``cell`` from what its kind returned (``flights``, ``safety``, ``result``, ``timing``,
    optionally ``status``)."""
    code, dirty = code_version()
    return {"schema": SCHEMA, "sweep": cell.sweep, "kind": cell.kind, "key": cell.key,
            "status": out.get("status", "ok"), "flights": out.get("flights", {}), "safety": out.get("safety", {}),
            "result": out.get("result", {}),
            "timing": {"wall_s": round(wall_s, 3), "load_1min": round(os.getloadavg()[0], 2), **out.get("timing", {})},
            "run": {"code": code, "dirty": dirty, "machine": machine(), "node": node or socket.gethostname(),
                    "executor": executor, "started": started, "attempts": attempts}}
