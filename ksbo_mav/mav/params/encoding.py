"""How a parameter's value travels in the float field of PARAM_SET / PARAM_VALUE, and when two values are the same.

INT32 values travel in the float field either C-cast (ArduPilot) or bytewise (PX4, spec); the encoding is a
property of the stack (:mod:`ksbo_mav.mav.stacks`), never guessed from the value. A set is verified against the
echo as the vehicle stores the value: integers exactly, REAL32 within float32 rounding.
"""

from __future__ import annotations

import math
import struct

import numpy as np

REAL32, REAL64 = 9, 10
#: MAV_PARAM_TYPE -> struct format of the integer inside the 4-byte param union (little-endian).
_INT_FORMATS = {1: "<B", 2: "<b", 3: "<H", 4: "<h", 5: "<I", 6: "<i"}


def encode(value: float, ptype: int, encoding: str) -> float:
    """Value -> the float carried in PARAM_SET/PARAM_VALUE.param_value."""
    if ptype not in _INT_FORMATS:
        return float(value)
    ival = int(round(value))
    if encoding == "bytewise":
        raw = struct.pack(_INT_FORMATS[ptype], ival).ljust(4, b"\0")
        return struct.unpack("<f", raw)[0]
    return float(ival)


def decode(wire: float, ptype: int, encoding: str) -> float:
    """param_value on the wire -> the parameter's value."""
    if ptype not in _INT_FORMATS:
        return float(wire)
    if encoding == "bytewise":
        fmt = _INT_FORMATS[ptype]
        raw = struct.pack("<f", wire)[: struct.calcsize(fmt)]
        return float(struct.unpack(fmt, raw)[0])
    return float(wire)


def same_value(a: float, b: float, ptype: int) -> bool:
    """Equal as the vehicle stores them: integers exactly, REAL32 within float32 rounding."""
    if not (math.isfinite(a) and math.isfinite(b)):
        return False
    if ptype in _INT_FORMATS:
        return int(round(a)) == int(round(b))
    fa, fb = float(np.float32(a)), float(np.float32(b))
    return abs(fa - fb) <= 1e-6 * max(1.0, abs(fa))
