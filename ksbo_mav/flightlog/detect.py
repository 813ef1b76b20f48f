"""Which kind of flight log a file is, from its first bytes (never from its name)."""

from __future__ import annotations

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
    return _by_scanning(p)


SCAN = 1 << 16  # bytes searched for a record start when the file does not begin with one


def _by_scanning(p: Path) -> str:
    """A tlog whose first record is valid whatever its timestamp, or one that starts mid-stream (a valid frame
    further in); a DataFlash log whose head is missing (FMT messages further in)."""
    from ksbo_mav.flightlog.tlog_frames import first_record

    with open(p, "rb") as fh:
        head = fh.read(SCAN)
    if len(head) < 8 + 8:
        raise InputError(f"log {p} is truncated or not a flight log: only {len(head)} byte(s)")
    at = first_record(head, len(head))
    df = head.find(DF_HEAD + bytes([DF_FMT]))
    if at is not None and (df < 0 or at <= df):
        return "tlog"
    if df >= 0 and head.find(DF_HEAD + bytes([DF_FMT]), df + 3) >= 0:
        return "bin"
    if b"uint64_t timestamp;" in head:  # ULog format definitions ('F' records) without the ULog header before them
        raise InputError(f"{p} looks like a PX4 ULog whose head is missing (no ULog header at offset 0, message "
                         f"formats further in): a ULog cannot be decoded without its header and every format "
                         f"definition; use the file as the vehicle wrote it")
    raise InputError(f"{p} is corrupted or not a flight log: its first bytes are neither a MAVLink .tlog record, "
                     f"an ArduPilot DataFlash .BIN header nor a PX4 ULog header")
