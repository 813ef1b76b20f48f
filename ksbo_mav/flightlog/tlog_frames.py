"""Framing of MAVLink tlog records: where a record starts, whether its frame's checksum holds, and where the next
valid record is after damaged or foreign bytes (a recording that began mid-stream, inserted garbage)."""

from __future__ import annotations


def frame_len(mm, start: int, n: int) -> int | None:
    """Length of the MAVLink frame at ``start`` from its header, or None if no frame can start there."""
    if start + 3 > n:
        return None
    if mm[start] == 0xFD:
        return 10 + mm[start + 1] + 2 + (13 if mm[start + 2] & 0x01 else 0)
    if mm[start] == 0xFE:
        return 6 + mm[start + 1] + 2
    return None


def valid_record(mm, pos: int, n: int, parser) -> bool:
    """Whether a tlog record starts at ``pos``: a frame follows the 8-byte timestamp and its checksum holds."""
    length = frame_len(mm, pos + 8, n)
    if length is None or pos + 8 + length > n:
        return False
    try:
        msg = parser.decode(bytearray(mm[pos + 8:pos + 8 + length]))
    except Exception:  # bad checksum, bad length
        return False
    return msg.get_msgId() >= 0  # an unknown message id has no CRC extra to check it by: not evidence


def resync(mm, pos: int, n: int, parser, limit: int = 1 << 20) -> int | None:
    """The next offset at or after ``pos`` (within ``limit`` bytes) where a valid record starts, or None."""
    end = min(n - 8, pos + limit)
    q = pos
    while q < end:
        hit = min((i for i in (mm.find(b"\xfd", q + 8, end + 8), mm.find(b"\xfe", q + 8, end + 8)) if i >= 0),
                  default=-1)
        if hit < 0:
            return None
        q = hit - 8
        if valid_record(mm, q, n, parser):
            return q
        q += 1
    return None
