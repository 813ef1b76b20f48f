"""Telemetry logs (.tlog): writing both directions of a link, and reading them back strictly.

A tlog record is ``uint64 big-endian µs since the Unix epoch`` followed by one raw MAVLink v1/v2 packet (the
format of pymavlink, MAVProxy, QGC; ``mavlogdump.py`` reads it). The low two bits of the timestamp are a link id:
received packets carry 0, packets we sent carry 3, as MAVProxy writes them (fact sheet 5.1).

pymavlink's own ``setup_logfile`` writes nothing on UDP links (fact sheet 5.2), so :class:`TlogWriter` is fed
from the connection's message hook and send callback instead (see :mod:`ksbo_mav.mav.link`).

:func:`read_tlog` is deliberately strict: a tlog is evidence for a score, so an empty, truncated or corrupted
file is an :class:`~ksbo_mav.errors.InputError` naming the byte offset, never a silently shorter flight.
"""

from __future__ import annotations

import os
import struct
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

from ksbo_mav.errors import InputError
from ksbo_mav.mav.wire import mavlink

LINK_RECEIVED = 0
LINK_SENT = 3

_V1, _V2 = 0xFE, 0xFD
#: Timestamps outside [2000-01-01, 2100-01-01] mean we are not reading a tlog (or are misaligned).
_USEC_MIN, _USEC_MAX = 946_684_800 * 10**6, 4_102_444_800 * 10**6


class TlogWriter:
    """Appends records to a .tlog; ``flush_every`` records are buffered between flushes (a crash loses at
    most those, and :meth:`close` fsyncs)."""

    def __init__(self, path: str | Path, flush_every: int = 64) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._fh: BinaryIO | None = open(self.path, "ab")
        self._flush_every = flush_every
        self._pending = 0
        self.records = 0

    def write(self, buf: bytes, link: int, usec: int | None = None) -> None:
        if self._fh is None:
            return
        usec = int(time.time() * 1e6) if usec is None else int(usec)
        self._fh.write(struct.pack(">Q", (usec & ~3) | (link & 3)) + bytes(buf))
        self.records += 1
        self._pending += 1
        if self._pending >= self._flush_every:
            self._fh.flush()
            self._pending = 0

    def close(self) -> None:
        if self._fh is not None:
            self._fh.flush()
            os.fsync(self._fh.fileno())
            self._fh.close()
            self._fh = None


@dataclass
class TlogRecord:
    usec: int  # wall-clock µs (link bits cleared)
    link: int  # 0 received, 3 sent (MAVProxy convention)
    msg: Any  # pymavlink MAVLink_message

    @property
    def sent(self) -> bool:
        return self.link == LINK_SENT


def read_tlog(path: str | Path) -> list[TlogRecord]:
    """Every record of a tlog, in file order.

    Raises:
        InputError: missing/empty file, a record cut short (truncated file), a bad start byte, an implausible
            timestamp or a checksum mismatch (corruption), each with the byte offset.
    """
    p = Path(path)
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read tlog {p}: {exc.strerror or exc}") from None
    if not data:
        raise InputError(f"tlog {p} is empty")
    parser = mavlink.MAVLink(None)
    parser.robust_parsing = False
    out: list[TlogRecord] = []
    pos, n = 0, len(data)
    while pos < n:
        if n - pos < 8 + 8:
            raise InputError(f"tlog {p} is truncated: {n - pos} stray byte(s) at offset {pos}")
        (stamp,) = struct.unpack_from(">Q", data, pos)
        if not _USEC_MIN <= stamp <= _USEC_MAX:
            raise InputError(f"tlog {p} is corrupted at offset {pos}: implausible timestamp (not a tlog?)")
        start = pos + 8
        magic = data[start]
        if magic == _V2:
            length = 10 + data[start + 1] + 2 + (13 if data[start + 2] & 0x01 else 0)
        elif magic == _V1:
            length = 6 + data[start + 1] + 2
        else:
            raise InputError(f"tlog {p} is corrupted at offset {start}: 0x{magic:02x} is not a MAVLink start byte")
        if start + length > n:
            raise InputError(f"tlog {p} is truncated: the record at offset {pos} needs {length} bytes, "
                             f"{n - start} remain")
        try:
            msg = parser.decode(bytearray(data[start:start + length]))
        except Exception as exc:  # pymavlink raises MAVError (bad CRC, unknown id, bad length)
            raise InputError(f"tlog {p} is corrupted at offset {start}: {exc}") from None
        out.append(TlogRecord(usec=stamp & ~3, link=stamp & 3, msg=msg))
        pos = start + length
    return out
