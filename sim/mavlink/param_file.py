"""The whole parameter table as ArduPilot's packed parameter file (``@PARAM/param.pck``), which a ground station
reads over MAVLink FTP instead of one PARAM_VALUE per parameter (ArduPilot serves it from 4.1; PX4 from PR #28435,
after its main of 2026-08-13). Format (ArduPilot ``libraries/AP_Filesystem/README.md``): a header ``<HHH`` (magic
0x671B, parameters in the file, parameters in total), then per parameter a type byte (1 int8, 2 int16, 3 int32,
4 float), a byte holding the length of the name it shares with the previous parameter (low nibble) and the length
less one of the rest (high nibble), the rest of the name, and the value."""

from __future__ import annotations

import struct

MAGIC = 0x671B
PCK_INT32, PCK_FLOAT = 3, 4


def pack(rows: list[tuple[str, float, bool]]) -> bytes:
    """``rows``: (name, value, is_int32) in the table's order."""
    out = bytearray(struct.pack("<HHH", MAGIC, len(rows), len(rows)))
    last = b""
    for name, value, is_int in rows:
        n = name.encode("ascii")
        common = 0
        while common < min(len(n) - 1, len(last), 15) and n[common] == last[common]:
            common += 1
        rest = n[common:]
        out += bytes([PCK_INT32 if is_int else PCK_FLOAT, common | ((len(rest) - 1) << 4)]) + rest
        out += struct.pack("<i", int(value)) if is_int else struct.pack("<f", float(value))
        last = n
    return bytes(out)
