"""ArduPilot DataFlash (``.BIN``) reader that streams: one pass over the file, only the wanted messages kept.

pymavlink's ``DFReader_binary`` mmaps the file and first indexes the offset of *every* message before it returns
the first one (see BENCHMARKS.md for what that costs on a 500 MB log). This reader walks the message chain once,
``CHUNK`` bytes at a time — ``0xA3 0x95 type`` then the body whose length the log's own FMT messages define — and
copies only the bodies of the wanted types into one ``bytearray`` per type, decoded at the end with numpy into
structured arrays. Memory is one chunk plus the kept messages' raw size (PSCN/PSCE/PSCD at 10 Hz: ~150 kB per
simulated minute), never the file's.

Resynchronising: where a message does not start with the header (bytes inserted or overwritten, a head cut off)
the walk scans for the next header that is followed by another and reports the span it skipped (bytes, and the
TimeUS on either side); a file that ends inside a message is cut, reported to the caller (``truncated``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.flightlog.detect import open_log
from ksbo_mav.flightlog.model import Skipped

HEAD1, HEAD2, FMT_TYPE, FMT_LEN = 0xA3, 0x95, 0x80, 89
# DataFlash format characters -> numpy dtype (little-endian) and the multiplier ArduPilot applies on read.
_DTYPE = {"a": ("<i2", 1, (32,)), "b": ("i1", 1, ()), "B": ("u1", 1, ()), "h": ("<i2", 1, ()),
          "H": ("<u2", 1, ()), "i": ("<i4", 1, ()), "I": ("<u4", 1, ()), "f": ("<f4", 1, ()),
          "d": ("<f8", 1, ()), "n": ("S4", 1, ()), "N": ("S16", 1, ()), "Z": ("S64", 1, ()),
          "c": ("<i2", 0.01, ()), "C": ("<u2", 0.01, ()), "e": ("<i4", 0.01, ()), "E": ("<u4", 0.01, ()),
          "L": ("<i4", 1e-7, ()), "M": ("u1", 1, ()), "q": ("<i8", 1, ()), "Q": ("<u8", 1, ()),
          "g": ("<f2", 1, ())}


@dataclass
class DFFormat:
    type: int
    name: str
    length: int  # whole message, header included
    format: str
    columns: list[str]

    def dtype(self) -> np.dtype:
        fields = []
        for ch, col in zip(self.format, self.columns):
            if ch not in _DTYPE:
                raise InputError(f"DataFlash format {self.name}: unknown type character {ch!r}")
            base, _, shape = _DTYPE[ch]
            fields.append((col, base, shape) if shape else (col, base))
        dt = np.dtype(fields)
        if dt.itemsize != self.length - 3:
            raise InputError(f"DataFlash format {self.name}: fields take {dt.itemsize} bytes, FMT says "
                             f"{self.length - 3}")
        return dt

    def scale(self, col: str) -> float:
        return _DTYPE[self.format[self.columns.index(col)]][1]


@dataclass
class DFContents:
    formats: dict[str, DFFormat]
    data: dict[str, np.ndarray]  # name -> structured array (raw units; see DFFormat.scale)
    counts: dict[str, int]  # messages seen per name (all types)
    size: int
    end: int  # offset after the last complete message
    truncated: bool  # the file ends inside a message
    messages: int = 0
    extra: dict = field(default_factory=dict)

    def column(self, name: str, col: str) -> np.ndarray:
        arr = self.data[name][col]
        s = self.formats[name].scale(col)
        return arr.astype(float) * s if s != 1 else arr.astype(float)


CHUNK = 8 << 20  # bytes read at a time: memory is bounded by this plus the kept messages


def read_dataflash(path: str | Path, wanted: set[str]) -> DFContents:
    """One streaming pass; damaged spans are skipped and listed in ``extra["skipped"]``."""
    p = Path(path)
    fh, size = open_log(p)
    with fh:
        return _walk(fh, size, wanted, p)


def _walk(fh, size: int, wanted: set[str], p: Path) -> DFContents:
    """Walk the message chain chunk by chunk (``CHUNK`` bytes plus at most one message carried over). Where the
    chain breaks (no header, a type without FMT), scan for the next header whose message is followed by another
    (or the end of the file) and record the span skipped."""
    lengths = [0] * 256
    lengths[FMT_TYPE] = FMT_LEN
    names: dict[int, str] = {FMT_TYPE: "FMT"}
    formats: dict[str, DFFormat] = {"FMT": DFFormat(FMT_TYPE, "FMT", FMT_LEN, "BBnNZ",
                                                    ["Type", "Length", "Name", "Format", "Columns"])}
    keep: dict[int, bytearray] = {}
    keep_at: list[bytearray | None] = [None] * 256  # the same buffers, indexed by type (hot loop)
    counts = [0] * 256
    n_msgs = 0
    skipped: list[Skipped] = []
    damage: Skipped | None = None  # a damaged span being skipped (its end not found yet)
    timeless: Skipped | None = None  # the last span, while no timed message has followed it
    last_t: float | None = None  # TimeUS of the last good message before the current chunk
    buf, pos, base, last = b"", 0, 0, -1
    while True:
        chunk = fh.read(CHUNK)
        eof = not chunk
        if last >= 0:
            last_t = _time_of(buf, last, names, formats) or last_t
        buf = buf[pos:] + chunk
        base += pos
        pos, n, last = 0, len(buf), -1
        while n - pos >= 3:
            if buf[pos] != HEAD1 or buf[pos + 1] != HEAD2 or not lengths[buf[pos + 2]]:
                if damage is None:
                    t0 = _time_of(buf, last, names, formats) if last >= 0 else last_t
                    damage = Skipped(base + pos, 0, t0)
                nxt = _next_header(buf, pos + 1, n, lengths, eof)
                if nxt is None:  # not in this chunk: keep its last bytes and read on
                    pos = max(pos, n - 2 - 3 - 255) if not eof else n
                    break
                pos = nxt
                damage.nbytes = base + pos - damage.offset
                damage.t_after = _time_of(buf, pos, names, formats)
                skipped.append(damage)
                timeless = damage if damage.t_after is None else None
                damage = None
                continue
            typ = buf[pos + 2]
            end = pos + lengths[typ]
            if end > n:
                break
            if damage is not None:  # the span ended at a chunk boundary
                damage.nbytes = base + pos - damage.offset
                damage.t_after = _time_of(buf, pos, names, formats)
                skipped.append(damage)
                damage = None
            counts[typ] += 1
            n_msgs += 1
            if timeless is not None and (tt := _time_of(buf, pos, names, formats)) is not None:
                timeless.t_after, timeless = tt, None  # the first timed message after a span
            if typ == FMT_TYPE:
                f = _parse_fmt(buf[pos + 3:end], p, base + pos)
                if f is not None and f.length >= 3:
                    lengths[f.type] = f.length
                    names[f.type] = f.name
                    formats[f.name] = f
                    if f.name in wanted and f.type not in keep:
                        keep[f.type] = keep_at[f.type] = bytearray()
            else:
                kept = keep_at[typ]
                if kept is not None:
                    kept += buf[pos + 3:end]
            last = pos
            pos = end
        if eof:
            break
    if damage is not None:  # damage up to the end of the file
        damage.nbytes = size - damage.offset
        skipped.append(damage)
        pos = n
    truncated = pos < n
    data: dict[str, np.ndarray] = {}
    for typ, kept in keep.items():
        f = formats[names[typ]]
        try:
            dt = f.dtype()
        except InputError:
            continue
        usable = len(kept) - len(kept) % dt.itemsize
        data[f.name] = np.frombuffer(bytes(kept[:usable]), dtype=dt)
    cnt = {names.get(t, str(t)): c for t, c in enumerate(counts) if c}
    return DFContents(formats, data, cnt, size, base + pos, truncated, n_msgs, {"skipped": skipped})


def _next_header(buf: bytes, frm: int, n: int, lengths: list[int], eof: bool) -> int | None:
    """Offset of the next message header in ``buf[frm:]`` whose type is defined and whose message is followed by
    another header (or ends the file); None if there is none in the buffer."""
    q = frm
    while True:
        q = buf.find(b"\xa3\x95", q)
        if q < 0 or q + 3 > n:
            return None
        length = lengths[buf[q + 2]]
        if length:
            e = q + length
            if e + 3 <= n:
                if buf[e] == HEAD1 and buf[e + 1] == HEAD2 and lengths[buf[e + 2]]:
                    return q
            elif eof and e <= n:
                return q
            elif not eof:
                return None  # decide with the next chunk
        q += 1


def _time_of(buf: bytes, at: int, names: dict[int, str], formats: dict[str, DFFormat]) -> float | None:
    """TimeUS (s) of the message at ``at`` when its format starts with one."""
    f = formats.get(names.get(buf[at + 2], ""))
    if f is None or not f.columns or f.columns[0] != "TimeUS" or f.format[:1] != "Q" or at + 11 > len(buf):
        return None
    return int.from_bytes(buf[at + 3:at + 11], "little") * 1e-6


def _parse_fmt(body: bytes, p: Path, pos: int) -> DFFormat | None:
    try:
        typ, length = body[0], body[1]
        name = body[2:6].rstrip(b"\0").decode("ascii")
        fmt = body[6:22].rstrip(b"\0").decode("ascii")
        cols = body[22:86].rstrip(b"\0").decode("ascii")
    except (UnicodeDecodeError, IndexError):
        return None  # a damaged FMT: its type stays undefined, its messages are skipped as damage
    return DFFormat(typ, name, length, fmt, cols.split(",") if cols else [])
