"""ArduPilot DataFlash (``.BIN``) reader that streams: one pass over the file, only the wanted messages kept.

pymavlink's ``DFReader_binary`` mmaps the file and first indexes the offset of *every* message before it returns
the first one (see BENCHMARKS.md for what that costs on a 500 MB log). This reader walks the message chain once,
``CHUNK`` bytes at a time — ``0xA3 0x95 type`` then the body whose length the log's own FMT messages define — and
copies only the bodies of the wanted types into one ``bytearray`` per type, decoded at the end with numpy into
structured arrays. Memory is one chunk plus the kept messages' raw size (PSCN/PSCE/PSCD at 10 Hz: ~150 kB per
simulated minute), never the file's.

Strict framing: a message that does not start with the header is corruption (error with the byte offset); a file
that ends inside a message is cut, reported to the caller (``truncated_at``) so it can decide whether what was cut
matters.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.flightlog.detect import open_log

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
    """One streaming pass; raises :class:`InputError` on corruption (never on a cut end: see ``truncated``)."""
    p = Path(path)
    fh, size = open_log(p)
    with fh:
        return _walk(fh, size, wanted, p)


def _walk(fh, size: int, wanted: set[str], p: Path) -> DFContents:
    """Walk the message chain chunk by chunk (``CHUNK`` bytes plus at most one message carried over)."""
    lengths = [0] * 256
    lengths[FMT_TYPE] = FMT_LEN
    names: dict[int, str] = {FMT_TYPE: "FMT"}
    formats: dict[str, DFFormat] = {"FMT": DFFormat(FMT_TYPE, "FMT", FMT_LEN, "BBnNZ",
                                                    ["Type", "Length", "Name", "Format", "Columns"])}
    keep: dict[int, bytearray] = {}
    keep_at: list[bytearray | None] = [None] * 256  # the same buffers, indexed by type (hot loop)
    counts = [0] * 256
    n_msgs = 0
    buf, pos, base = b"", 0, 0
    while True:
        chunk = fh.read(CHUNK)
        eof = not chunk
        buf = buf[pos:] + chunk
        base += pos
        pos, n = 0, len(buf)
        while n - pos >= 3:
            if buf[pos] != HEAD1 or buf[pos + 1] != HEAD2:
                raise InputError(f"DataFlash log {p} is corrupted at offset {base + pos}: no message header "
                                 f"(0xA3 0x95) where message {n_msgs + 1} should start")
            typ = buf[pos + 2]
            length = lengths[typ]
            if not length:
                raise InputError(f"DataFlash log {p} is corrupted at offset {base + pos}: message type {typ} has "
                                 f"no FMT definition before it")
            end = pos + length
            if end > n:
                break
            counts[typ] += 1
            n_msgs += 1
            if typ == FMT_TYPE:
                f = _parse_fmt(buf[pos + 3:end], p, base + pos)
                if f.length < 3:
                    raise InputError(f"DataFlash log {p} is corrupted at offset {base + pos}: FMT of {f.name} with "
                                     f"length {f.length}")
                lengths[f.type] = f.length
                names[f.type] = f.name
                formats[f.name] = f
                if f.name in wanted and f.type not in keep:
                    keep[f.type] = keep_at[f.type] = bytearray()
            else:
                kept = keep_at[typ]
                if kept is not None:
                    kept += buf[pos + 3:end]
            pos = end
        if eof:
            break
    truncated = pos < n
    data: dict[str, np.ndarray] = {}
    for typ, kept in keep.items():
        f = formats[names[typ]]
        data[f.name] = np.frombuffer(bytes(kept), dtype=f.dtype()) if kept else np.zeros(0, dtype=f.dtype())
    cnt = {names.get(t, str(t)): c for t, c in enumerate(counts) if c}
    return DFContents(formats, data, cnt, size, base + pos, truncated, n_msgs)


def _parse_fmt(body: bytes, p: Path, pos: int) -> DFFormat:
    try:
        typ, length = body[0], body[1]
        name = body[2:6].rstrip(b"\0").decode("ascii")
        fmt = body[6:22].rstrip(b"\0").decode("ascii")
        cols = body[22:86].rstrip(b"\0").decode("ascii")
    except (UnicodeDecodeError, IndexError):
        raise InputError(f"DataFlash log {p} is corrupted at offset {pos}: unreadable FMT message") from None
    return DFFormat(typ, name, length, fmt, cols.split(",") if cols else [])
