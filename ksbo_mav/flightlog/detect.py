"""Which kind of flight log a file is, from its first bytes (never from its name)."""

from __future__ import annotations

import mmap
from pathlib import Path

from ksbo_mav.errors import InputError

ULOG_MAGIC = b"ULog\x01\x12\x35"
DF_HEAD = b"\xa3\x95"
DF_FMT = 0x80
FORMATS = {"tlog": "MAVLink telemetry log (.tlog)", "bin": "ArduPilot DataFlash log (.BIN)", "ulg": "PX4 ULog (.ulg)"}


def open_log(p: Path):
    """A log opened for binary reading, positioned at 0, with its size; InputError (one line) when missing or
    empty. Returns ``(file, size)``; the caller closes the file."""
    try:
        fh = open(p, "rb")
    except OSError as exc:
        raise InputError(f"cannot read log {p}: {exc.strerror or exc}") from None
    size = fh.seek(0, 2)
    fh.seek(0)
    if size == 0:
        fh.close()
        raise InputError(f"log {p} is empty")
    return fh, size


def detect_format(path: str | Path) -> str:
    """``"tlog"``, ``"bin"`` or ``"ulg"``; :class:`InputError` (one line) for a missing, empty or foreign file."""
    p = Path(path)
    try:
        with open(p, "rb") as fh:
            head = fh.read(64)
    except OSError as exc:
        raise InputError(f"cannot read log {p}: {exc.strerror or exc}") from None
    if not head:
        raise InputError(f"log {p} is empty")
    if head.startswith(ULOG_MAGIC[:4]):
        if len(head) < 16:
            raise InputError(f"PX4 ULog {p} is truncated: {len(head)}-byte file, the header alone is 16 bytes")
        if head[:7] != ULOG_MAGIC:
            raise InputError(f"PX4 ULog {p} is corrupted: bad header magic")
        return "ulg"
    if head.startswith(DF_HEAD):
        if len(head) < 3 or head[2] != DF_FMT:
            raise InputError(f"DataFlash log {p} is corrupted: it must start with a FMT message")
        return "bin"
    if len(head) >= 10:
        if _holds_tlog_records(p):
            return "tlog"
    elif len(head) < 10:
        raise InputError(f"log {p} is truncated or not a flight log: only {len(head)} byte(s)")
    raise InputError(f"{p} is corrupted or not a flight log: its first bytes are neither a MAVLink .tlog record, "
                     f"an ArduPilot DataFlash .BIN header nor a PX4 ULog header")


def _holds_tlog_records(p: Path) -> bool:
    """Whether a MAVLink tlog record (8-byte timestamp, a frame whose checksum holds) starts in the first megabyte
    of ``p``: at offset 0, or later when the recording began mid-stream or the head is damaged."""
    from ksbo_mav.flightlog.tlog_frames import resync
    from ksbo_mav.mav.wire import mavlink

    with open(p, "rb") as fh, mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as mm:
        return resync(mm, 0, len(mm), mavlink.MAVLink(None)) is not None
