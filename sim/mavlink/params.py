"""Parameter service (fact sheet section 2): list, read by name or index, set with the PARAM_VALUE echo.

Autopilot behaviour reproduced here:

* PARAM_REQUEST_LIST streams every parameter with param_count and param_index 0..count-1.
* PARAM_REQUEST_READ with param_index -1 reads by name, otherwise by index; unknown names/indices: no reply.
* PARAM_SET of an unknown name is ignored silently (no PARAM_VALUE, no STATUSTEXT), as ArduPilot SITL does.
* PARAM_SET of a known name always answers with a PARAM_VALUE broadcast carrying the *current* value, also
  when the write was refused (out of range, non-finite, read-only); a refusal also sends a STATUSTEXT.
* Values are stored as float32 (REAL32) or int32 (INT32), so what is read back is exactly what is flown.
  INT32 values travel in the float field C-cast (ArduPilot, ours) or bytewise (PX4), per personality.
* Optional persistence: every accepted write rewrites a MAVProxy-style ``NAME VALUE`` file (atomic rename),
  like an autopilot's EEPROM; fault-injection switches are volatile so a restarted vehicle never boots faulty.
"""

from __future__ import annotations

import math
import os
import struct
import sys
from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

from ksbo_sim.errors import SimInputError
from ksbo_sim.vehicle import ParamSpec

MAV_PARAM_TYPE_INT32 = 6
MAV_PARAM_TYPE_REAL32 = 9
MAV_SEVERITY_WARNING = 4


def encode_int(value: int, encoding: str) -> float:
    """INT32 value -> the float carried in PARAM_VALUE.param_value."""
    if encoding == "bytewise":
        return struct.unpack("<f", struct.pack("<i", int(value)))[0]
    return float(int(value))


def decode_int(wire: float, encoding: str) -> float:
    """param_value of a PARAM_SET for an INT32 parameter -> the integer meant (may be non-finite if garbage)."""
    if encoding == "bytewise":
        return float(struct.unpack("<i", struct.pack("<f", wire))[0])
    return wire if not math.isfinite(wire) else float(round(wire))


def _stored(spec: ParamSpec, value: float) -> float:
    return float(int(value)) if spec.type == "INT32" else float(np.float32(value))


class ParamTable:
    """The vehicle's parameters; ``on_change(name, value)`` applies an accepted value to its owner."""

    def __init__(self, specs: Iterable[ParamSpec], on_change: Callable[[str, float], None], encoding: str,
                 readonly: Iterable[str] = (), volatile: Iterable[str] = (), path: str | Path | None = None,
                 echo_index: bool = True) -> None:
        self.specs = list(specs)
        names = [s.name for s in self.specs]
        if len(set(names)) != len(names) or any(len(n) > 16 for n in names):
            raise ValueError("parameter names must be unique and at most 16 characters")
        self._index = {s.name: i for i, s in enumerate(self.specs)}
        self.values = {s.name: _stored(s, s.default) for s in self.specs}
        self._on_change = on_change
        self.encoding = encoding
        self.readonly = set(readonly)
        self.volatile = set(volatile)
        self.echo_index = echo_index
        self.path = Path(path) if path else None
        for name, value in self.values.items():  # the owner flies the stored (float32) value, not the spec's
            on_change(name, value)
        self.send: Callable[[str, int], None] = lambda name, index: None  # set by the server
        self.statustext: Callable[[int, str], None] = lambda sev, text: None
        #: Fault injection: returns a refusal reason to make a PARAM_SET fail (echo of the old value).
        self.write_fault: Callable[[str], str | None] = lambda name: None
        if self.path is not None and not self.path.parent.is_dir():
            raise SimInputError(f"parameter file {self.path}: directory does not exist")
        if self.path is not None and self.path.exists():
            self._load(self.path)

    # --- local access ----------------------------------------------------------------------------------
    def __getitem__(self, name: str) -> float:
        return self.values[name]

    def spec(self, name: str) -> ParamSpec:
        return self.specs[self._index[name]]

    def set_local(self, name: str, value: float, persist: bool = True) -> str | None:
        """Validate and apply a value; returns a refusal reason or None. Used by PARAM_SET, files and CLI."""
        spec = self.specs[self._index[name]]
        if name in self.readonly:
            return f"Param write denied: {name}"
        if not math.isfinite(value):
            return f"Param {name}: non-finite value refused"
        if not spec.min <= value <= spec.max:
            return f"Param {name}: {value:g} outside [{spec.min:g}, {spec.max:g}]"
        new = _stored(spec, value)
        changed = new != self.values[name]
        self.values[name] = new
        self._on_change(name, new)
        if changed and persist and self.path is not None and name not in self.volatile:
            try:
                self._save(self.path)
            except OSError as exc:  # the value is in effect; only persistence failed (as a worn-out EEPROM)
                print(f"warning: cannot write {self.path}: {exc.strerror or exc}", file=sys.stderr)
        return None

    def force(self, name: str, value: float) -> None:
        """Set a value bypassing checks (read-only status values, fault switches resetting themselves)."""
        self.values[name] = _stored(self.spec(name), value)
        self._on_change(name, self.values[name])

    def wire_value(self, name: str) -> tuple[float, int]:
        spec = self.spec(name)
        if spec.type == "INT32":
            return encode_int(int(self.values[name]), self.encoding), MAV_PARAM_TYPE_INT32
        return self.values[name], MAV_PARAM_TYPE_REAL32

    # --- MAVLink ---------------------------------------------------------------------------------------
    def handle(self, msg) -> None:
        kind = msg.get_type()
        if kind == "PARAM_REQUEST_LIST":
            for i, spec in enumerate(self.specs):
                self.send(spec.name, i)
        elif kind == "PARAM_REQUEST_READ":
            if msg.param_index >= 0:
                if msg.param_index < len(self.specs):
                    self.send(self.specs[msg.param_index].name, msg.param_index)
            elif msg.param_id in self._index:
                self.send(msg.param_id, self._index[msg.param_id])
        elif kind == "PARAM_SET":
            name = msg.param_id
            if name not in self._index:
                return  # unknown names: silence, as an autopilot does
            spec = self.spec(name)
            value = decode_int(msg.param_value, self.encoding) if spec.type == "INT32" else float(msg.param_value)
            reason = self.write_fault(name) or self.set_local(name, value)
            if reason:
                self.statustext(MAV_SEVERITY_WARNING, reason)
            # ArduPilot echoes with param_index -1, which is 65535 in the uint16 field.
            self.send(name, self._index[name] if self.echo_index else 65535)

    # --- persistence -----------------------------------------------------------------------------------
    def _load(self, path: Path) -> None:
        try:
            text = path.read_text()
        except (OSError, UnicodeDecodeError) as exc:
            raise SimInputError(f"cannot read parameter file {path}: {exc}") from None
        for lineno, line in enumerate(text.splitlines(), 1):
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            parts = line.replace(",", " ").split()
            try:
                name, value = parts[0], float(parts[1])
                if len(parts) != 2:
                    raise ValueError
            except (IndexError, ValueError):
                raise SimInputError(f"{path}:{lineno}: expected 'NAME VALUE', got {line!r}") from None
            if name in self.readonly or name in self.volatile:
                continue
            if name not in self._index:
                print(f"warning: {path}:{lineno}: unknown parameter {name} ignored", file=sys.stderr)
                continue
            reason = self.set_local(name, value, persist=False)
            if reason:
                raise SimInputError(f"{path}:{lineno}: {reason}")

    def _save(self, path: Path) -> None:
        tmp = path.with_name(path.name + ".tmp")
        with open(tmp, "w") as fh:
            fh.write("# ksbo-mav sim parameters (written on every accepted PARAM_SET)\n")
            for spec in self.specs:
                if spec.name not in self.volatile and spec.name not in self.readonly:
                    v = self.values[spec.name]
                    fh.write(f"{spec.name} {int(v) if spec.type == 'INT32' else repr(v)}\n")
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
