"""Records of a MAVLink telemetry log, found by framing and CRC, resynchronising over damage.

A tlog is a sequence of records: an 8-byte big-endian timestamp (µs; any value — a ground station without a clock
writes small ones) followed by one MAVLink 1 (``0xFE``) or 2 (``0xFD``) frame. :class:`TlogScanner` walks them;
where a record does not start a valid frame (recording began mid-stream, bytes inserted or overwritten), it scans
forward to the next frame whose CRC checks (with the message's CRC_EXTRA) and records the span it skipped.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

from ksbo_mav.flightlog.model import Skipped

_DAY_US = 86_400 * 10**6


def _mavlink():
    from ksbo_mav.mav.wire import mavlink

    return mavlink


def frame_length(buf, s: int, n: int) -> int:
    """Length of the MAVLink frame at ``s`` if its CRC checks, 0 if it is not a valid frame, -1 if the buffer ends
    inside it."""
    magic = buf[s]
    if magic == 0xFD:
        if s + 10 > n:
            return -1
        plen = buf[s + 1]
        hdr, msgid = 10, buf[s + 7] | (buf[s + 8] << 8) | (buf[s + 9] << 16)
        length = 12 + plen + (13 if buf[s + 2] & 0x01 else 0)
    elif magic == 0xFE:
        if s + 6 > n:
            return -1
        plen = buf[s + 1]
        hdr, msgid, length = 6, buf[s + 5], 8 + plen
    else:
        return 0
    if s + length > n:
        return -1
    mav = _mavlink()
    cls = mav.mavlink_map.get(msgid)
    if cls is None:
        return 0
    crc = mav.x25crc(bytes(buf[s + 1:s + hdr + plen]))
    crc.accumulate(bytes((cls.crc_extra,)))
    got = buf[s + hdr + plen] | (buf[s + hdr + plen + 1] << 8)
    return length if crc.crc == got else 0


def first_record(buf, n: int, limit: int = 1 << 16) -> int | None:
    """Offset of the first tlog record in ``buf[:limit]`` (a frame with a good CRC, confirmed by the next record
    when it is not at offset 0), or None."""
    s = 8
    while s < min(n, limit):
        if buf[s] in (0xFE, 0xFD):
            length = frame_length(buf, s, n)
            if length > 0:
                nxt = s + length
                if s == 8 or nxt == n or (nxt + 8 < n and frame_length(buf, nxt + 8, n) > 0):
                    return s - 8
        s += 1
    return None


@dataclass
class TlogScanner:
    """Iterate ``(stamp_us, frame_start, length, msgid, src)`` over the good records; ``skipped`` lists the damaged
    spans, ``cut`` the offset of a record the file ends inside (None when it ends on a record boundary)."""

    buf: object
    n: int
    skipped: list[Skipped] = field(default_factory=list)
    cut: int | None = None
    records: int = 0

    def __iter__(self):
        buf, n = self.buf, self.n
        pos, prev = 0, None
        while pos < n:
            if n - pos < 8 + 6:
                self.cut = pos
                break
            start = pos + 8
            (stamp,) = struct.unpack_from(">Q", buf, pos)
            length = frame_length(buf, start, n)
            if length == 0 and buf[start] in (0xFE, 0xFD):
                length = self._unknown_id(start)
            if length == -1 and (prev is None or abs(stamp - prev) < _DAY_US):
                self.cut = pos
                break
            if length <= 0 or (prev is not None and abs(stamp - prev) >= _DAY_US):
                nxt = self._resync(pos + 1)
                self.skipped.append(Skipped(pos, (nxt if nxt is not None else n) - pos))
                if nxt is None:
                    break
                pos = nxt
                continue
            prev = stamp
            self.records += 1
            if buf[start] == 0xFD:
                msgid = buf[start + 7] | (buf[start + 8] << 8) | (buf[start + 9] << 16)
                src = (buf[start + 5], buf[start + 6])
            else:
                msgid, src = buf[start + 5], (buf[start + 3], buf[start + 4])
            yield stamp, start, length, msgid, src
            pos = start + length

    def _unknown_id(self, s: int) -> int:
        """A frame of a message this dialect does not know cannot be CRC-checked: accept it when the record after
        it starts a frame too (or the file ends there)."""
        buf, n = self.buf, self.n
        if buf[s] == 0xFD:
            if s + 10 > n:
                return 0
            msgid = buf[s + 7] | (buf[s + 8] << 8) | (buf[s + 9] << 16)
            length = 12 + buf[s + 1] + (13 if buf[s + 2] & 0x01 else 0)
        else:
            msgid, length = buf[s + 5], 8 + buf[s + 1]
        if msgid in _mavlink().mavlink_map:
            return 0  # known id, bad CRC
        nxt = s + length
        return length if nxt == n or (nxt + 8 < n and buf[nxt + 8] in (0xFE, 0xFD)) else 0

    def _resync(self, frm: int) -> int | None:
        """Offset of the next record whose frame checks (confirmed by the record after it), or None."""
        buf, n = self.buf, self.n
        s = frm + 8
        while s < n:
            a = buf.find(b"\xfe", s)
            b = buf.find(b"\xfd", s)
            cands = [x for x in (a, b) if x >= 0]
            if not cands:
                return None
            s = min(cands)
            length = frame_length(buf, s, n)
            if length > 0:
                nxt = s + length
                if nxt == n or nxt + 8 + 6 > n or frame_length(buf, nxt + 8, n) != 0:
                    return s - 8
            s += 1
        return None
