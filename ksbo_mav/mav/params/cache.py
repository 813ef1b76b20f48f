"""A vehicle's full parameter set kept on disk, reused while the vehicle says nothing changed.

PX4 answers PARAM_REQUEST_READ of the name ``_HASH_CHECK`` (index -1) with one PARAM_VALUE whose four bytes are a
CRC32 of every used parameter's name and value (``param_count`` beside it), as QGroundControl uses it. A set saved
under that hash and count is the vehicle's set while the vehicle reports the same pair: one round trip instead
of ~900 PARAM_VALUEs (23 s over a 4 kB/s radio, minutes over a lossy one). A set is saved only when the hash read
after the download equals the one read before, so nothing changed while it came.

ArduPilot has no such hash; there MAVLink FTP is the fast path (:mod:`ksbo_mav.mav.params.ftp_download`) and no cache is
kept.

Files: ``<cache dir>/<stack>-<hash:08x>-<count>.json`` ({"names": [...], "values": [...], "types": [...]} in
index order). The directory is ``$KSBO_MAV_CACHE_DIR``, else ``$XDG_CACHE_HOME/ksbo-mav/params``, else
``~/.cache/ksbo-mav/params``. A damaged or mismatched file is ignored (and the set downloaded), never trusted.
"""

from __future__ import annotations

import json
import os
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ksbo_mav.mav.link import Link

HASH_PARAM = "_HASH_CHECK"


def cache_dir() -> Path:
    """Where parameter sets are kept (see the module docstring)."""
    if os.environ.get("KSBO_MAV_CACHE_DIR"):
        return Path(os.environ["KSBO_MAV_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "ksbo-mav" / "params"


@dataclass(frozen=True)
class ParamHash:
    """The vehicle's word on its parameter set: CRC32 ``value`` over ``count`` parameters."""

    value: int
    count: int

    def stem(self, stack: str) -> str:
        return f"{stack}-{self.value:08x}-{self.count}"


def read_hash(link: Link, timeout: float = 1.0, attempts: int = 3) -> ParamHash | None:
    """Ask for ``_HASH_CHECK``; None when the vehicle does not answer (ArduPilot and our simulator ignore the
    unknown name)."""
    def is_hash(m: Any) -> bool:
        return m.get_type() == "PARAM_VALUE" and m.param_id == HASH_PARAM and link.is_vehicle(m)

    for _ in range(attempts):
        link.send(link.mav.param_request_read_encode(link.target_system, link.target_component,
                                                     HASH_PARAM.encode("ascii"), -1))
        msg = link.wait(is_hash, timeout)
        if msg is not None:
            # the CRC's four bytes travel in the float field
            return ParamHash(struct.unpack("<I", struct.pack("<f", msg.param_value))[0], int(msg.param_count))
    return None


def load(stack: str, h: ParamHash, directory: Path | None = None) -> list[tuple[str, float, int]] | None:
    """The set saved under ``h`` as [(name, value, MAV_PARAM_TYPE)] in index order, or None (absent, damaged, or
    not ``h.count`` parameters)."""
    path = (directory or cache_dir()) / f"{h.stem(stack)}.json"
    try:
        doc = json.loads(path.read_text())
        rows = list(zip(doc["names"], doc["values"], doc["types"], strict=True))
        rows = [(str(n), float(v), int(t)) for n, v, t in rows]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return rows if len(rows) == h.count and len({n for n, _, _ in rows}) == h.count else None


def save(stack: str, h: ParamHash, rows: list[tuple[str, float, int]], directory: Path | None = None) -> Path | None:
    """Keep ``rows`` (index order) under ``h``; returns the file, or None when it could not be written (a cache
    is a convenience: a read-only home never stops a campaign)."""
    d = directory or cache_dir()
    path = d / f"{h.stem(stack)}.json"
    try:
        d.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp")
        tmp.write_text(json.dumps({"names": [r[0] for r in rows], "values": [r[1] for r in rows],
                                   "types": [r[2] for r in rows]}))
        tmp.replace(path)
    except OSError:
        return None
    return path
