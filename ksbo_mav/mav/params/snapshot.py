"""Parameter snapshots on disk: the complete parameter list before the first write, in three files.

* ``<stem>.param`` — MAVProxy / Mission Planner ``NAME VALUE`` (loadable by ``param load``);
* ``<stem>.params`` — QGroundControl's tab-separated format with types, full precision (bit-exact reloads);
* ``<stem>.json`` — vehicle identity, stack, name generation, the profile's gain names and baseline, every
  parameter with its type, and a SHA-256 over the sorted list, so a restore can check it talks to the same
  vehicle and that the file was not edited.

Every file is written to a temporary name, fsynced and renamed, then the directory is fsynced: after
:func:`write_snapshot` returns, the snapshot survives a crash of the tool or the machine.
"""

from __future__ import annotations

import hashlib
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ksbo_mav.errors import InputError
from ksbo_mav.jsonio import fsync_write
from ksbo_mav.mav.params.client import Param

SNAPSHOT_VERSION = 1


def params_hash(values: dict[str, tuple[float, int]]) -> str:
    h = hashlib.sha256()
    for name in sorted(values):
        v, t = values[name]
        h.update(f"{name}\t{float(v)!r}\t{int(t)}\n".encode())
    return h.hexdigest()


def _fmt(value: float, ptype: int) -> str:
    return str(int(round(value))) if ptype in (1, 2, 3, 4, 5, 6) else repr(float(value))


@dataclass
class Snapshot:
    """A loaded snapshot (see module docstring)."""

    path: Path
    identity: dict[str, Any]
    stack: str
    generation: str
    profile: str
    gain_names: list[str]  # vehicle parameter names of the profile's gains
    params: dict[str, tuple[float, int]]  # name -> (value, MAV_PARAM_TYPE)

    def baseline(self) -> dict[str, float]:
        """{vehicle name: value} of the tuned gains when the snapshot was taken."""
        return {n: self.params[n][0] for n in self.gain_names}

    def off(self, now: dict[str, float]) -> dict[str, tuple[float, float | None]]:
        """Parameters whose value in ``now`` (a full read of the vehicle) is not the snapshot's, or missing, except
        those the autopilot writes itself (``ksbo_mav.mav.stacks.AUTOPILOT_UPDATED``): {name: (snapshot, now)}."""
        from ksbo_mav.mav.stacks import autopilot_updated

        return {n: (v, now.get(n)) for n, (v, _) in self.params.items() if not autopilot_updated(self.stack, n)
                and (n not in now or abs(now[n] - v) > 1e-6 * max(1.0, abs(v)))}


def write_snapshot(stem: Path, identity: dict[str, Any], stack: str, generation: str, profile: str,
                   gain_names: list[str], table: dict[str, Param]) -> Snapshot:
    """Write ``stem``.param/.params/.json durably; returns the snapshot."""
    params = {p.name: (float(p.value), int(p.ptype)) for p in table.values()}
    missing = [n for n in gain_names if n not in params]
    if missing:
        raise InputError(f"snapshot would miss the tuned parameter(s) {', '.join(missing)}")
    stem = Path(stem)
    sysid, compid = int(identity.get("sysid", 1)), int(identity.get("compid", 1))
    rows = sorted(params.items())
    fsync_write(stem.with_suffix(".param"),
                f"# ksbo-mav snapshot {time.strftime('%Y-%m-%d %H:%M:%S UTC', time.gmtime())}\n"
                + "".join(f"{n} {_fmt(v, t)}\n" for n, (v, t) in rows))
    fsync_write(stem.with_suffix(".params"),
                f"# Onboard parameters for Vehicle {sysid}\n#\n# Vehicle-Id Component-Id Name Value Type\n"
                + "".join(f"{sysid}\t{compid}\t{n}\t{_fmt(v, t)}\t{t}\n" for n, (v, t) in rows))
    doc = {"version": SNAPSHOT_VERSION, "created_unix": time.time(), "identity": identity, "stack": stack,
           "generation": generation, "profile": profile, "gain_names": list(gain_names),
           "params": {n: [v, t] for n, (v, t) in rows}, "sha256": params_hash(params)}
    fsync_write(stem.with_suffix(".json"), json.dumps(doc, indent=1))
    return Snapshot(stem.with_suffix(".json"), identity, stack, generation, profile, list(gain_names), params)


def load_snapshot(path: str | Path) -> Snapshot:
    """Load ``X.json`` (or a campaign directory holding ``snapshot/vehicle.json``); clear errors otherwise."""
    p = Path(path)
    if p.is_dir():
        found = [f for f in (p / "snapshot" / "vehicle.json", p / "vehicle.json") if f.exists()]
        if not found:
            raise InputError(f"{p} holds no snapshot: neither {p / 'snapshot' / 'vehicle.json'} (a campaign's) nor "
                             f"{p / 'vehicle.json'}; give the campaign directory `ksbo-mav tune` wrote, or its "
                             "snapshot/vehicle.json")
        p = found[0]
    elif p.suffix in (".param", ".params"):
        p = p.with_suffix(".json")
    try:
        doc = json.loads(p.read_text())
    except OSError as exc:
        raise InputError(f"cannot read snapshot {p}: {exc.strerror or exc}") from None
    except json.JSONDecodeError as exc:
        raise InputError(f"snapshot {p} is not valid JSON: {exc}") from None
    try:
        params = {str(n): (float(v), int(t)) for n, (v, t) in doc["params"].items()}
        snap = Snapshot(p, dict(doc["identity"]), str(doc["stack"]), str(doc.get("generation", "")),
                        str(doc["profile"]), [str(n) for n in doc["gain_names"]], params)
        digest = str(doc["sha256"])
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"snapshot {p} is incomplete or malformed: {exc!r}") from None
    if params_hash(params) != digest:
        raise InputError(f"snapshot {p} fails its checksum (edited or damaged); refusing to use it")
    missing = [n for n in snap.gain_names if n not in params]
    if missing:
        raise InputError(f"snapshot {p} lacks the tuned parameter(s) {', '.join(missing)}")
    return snap


def write_param_files(stem: Path, values: dict[str, float], types: dict[str, int], sysid: int = 1,
                      compid: int = 1) -> None:
    """Export a gain set as ``stem``.param and ``stem``.params (for `accept` and reports)."""
    rows = sorted(values.items())
    fsync_write(stem.with_suffix(".param"), "".join(f"{n} {_fmt(v, types.get(n, 9))}\n" for n, v in rows))
    fsync_write(stem.with_suffix(".params"),
                f"# Onboard parameters for Vehicle {sysid}\n#\n# Vehicle-Id Component-Id Name Value Type\n"
                + "".join(f"{sysid}\t{compid}\t{n}\t{_fmt(v, types.get(n, 9))}\t{types.get(n, 9)}\n"
                          for n, v in rows))
