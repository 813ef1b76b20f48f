"""PX4 ULog records, read for a few topics, resynchronising over damage.

A ULog is a 16-byte header then records ``uint16 size, uint8 type, payload``: definitions (``F`` formats, ``I``
info, ``P`` parameters ...) then data (``A`` subscriptions, ``D`` samples, ``L``/``C`` logged text, ``S`` sync).
Where a record is implausible (an unknown type, a sample for a subscription that does not exist or of the wrong
size) the reader scans for the next sample record of a known subscription that is followed by another plausible
record, and reports the span it skipped with the sample times on either side.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.flightlog.model import Skipped

MAGIC = b"ULog\x01\x12\x35"
TYPES = set(b"BFIMPQARDLCSO")
_BASE = {"int8_t": "i1", "uint8_t": "u1", "int16_t": "<i2", "uint16_t": "<u2", "int32_t": "<i4", "uint32_t": "<u4",
         "int64_t": "<i8", "uint64_t": "<u8", "float": "<f4", "double": "<f8", "bool": "u1", "char": "S1"}


@dataclass
class ULogContents:
    data: dict[str, np.ndarray]  # topic -> structured samples (multi instance 0)
    messages: list[tuple[int, str]]  # (timestamp µs, text) of logged messages
    info: dict[str, object]
    skipped: list[Skipped] = field(default_factory=list)
    cut: int | None = None  # offset of a record the file ends inside
    size: int = 0


def _dtype(name: str, formats: dict[str, str], depth: int = 0) -> np.dtype:
    if depth > 8 or name not in formats:
        raise InputError(f"ULog format {name!r} is missing or nested too deeply")
    fields, off = [], 0
    for decl in filter(None, (x.strip() for x in formats[name].split(";"))):
        typ, _, fname = decl.partition(" ")
        count = 1
        if "[" in typ:
            typ, cnt = typ[:-1].split("[")
            count = int(cnt)
        base = np.dtype(_BASE[typ]) if typ in _BASE else _dtype(typ, formats, depth + 1)
        dt = np.dtype((base, (count,))) if count > 1 or typ == "char" else base
        fields.append((fname, dt, off))
        off += dt.itemsize
    return np.dtype({"names": [f[0] for f in fields], "formats": [f[1] for f in fields],
                     "offsets": [f[2] for f in fields], "itemsize": off})


def read_ulog(buf: bytes, topics: list[str]) -> ULogContents:
    n = len(buf)
    if n < 16 or buf[:7] != MAGIC:
        raise InputError("bad header magic" if n >= 16 else f"{n}-byte file, the header alone is 16 bytes")
    formats: dict[str, str] = {}
    subs: dict[int, tuple[str, np.dtype, int]] = {}  # msg_id -> (topic, dtype, multi_id)
    rows: dict[int, list[bytes]] = {}
    out = ULogContents({}, [], {}, size=n)
    pos, last_t, damage = 16, None, None
    while pos < n:
        if n - pos < 3:
            out.cut = pos
            break
        size, typ = struct.unpack_from("<HB", buf, pos)
        end = pos + 3 + size
        why = _implausible(buf, pos, size, typ, subs)
        if why is None and end > n:
            out.cut = pos
            break
        if why is not None:
            if damage is None:
                damage = Skipped(pos, 0, last_t, why=why)
            nxt = _resync(buf, pos + 1, subs)
            damage.nbytes = (nxt if nxt is not None else n) - damage.offset
            if nxt is None:
                out.skipped.append(damage)
                break
            pos = nxt
            continue
        body = buf[pos + 3:end]
        if typ == ord("D"):
            msg_id = body[0] | (body[1] << 8)
            t = int.from_bytes(body[2:10], "little") if size >= 10 else None
            if damage is not None:
                damage.t_after = None if t is None else t * 1e-6
                out.skipped.append(damage)
                damage = None
            if t is not None:
                last_t = t * 1e-6
            if msg_id in rows:
                rows[msg_id].append(body[2:])
        elif typ == ord("F"):
            name, _, spec = body.decode("ascii", "replace").partition(":")
            formats[name] = spec
        elif typ == ord("A") and size >= 3:
            name = body[3:].decode("ascii", "replace")
            try:
                dt = _dtype(name, formats)
            except (InputError, ValueError, KeyError):
                dt = None
            if dt is not None:
                subs[body[1] | (body[2] << 8)] = (name, dt, body[0])
                if name in topics and body[0] == 0:
                    rows[body[1] | (body[2] << 8)] = []
        elif typ in (ord("L"), ord("C")) and size >= 9:
            off = 1 if typ == ord("L") else 3
            out.messages.append((int.from_bytes(body[off:off + 8], "little"),
                                 body[off + 8:].decode("utf-8", "replace")))
        elif typ == ord("I") and size >= 1:
            klen = body[0]
            key = body[1:1 + klen].decode("ascii", "replace")
            if key.endswith(" ver_sw_release") and size >= 1 + klen + 4:
                out.info["ver_sw_release"] = int.from_bytes(body[1 + klen:1 + klen + 4], "little")
            elif key.endswith(" ver_sw"):
                out.info["ver_sw"] = body[1 + klen:].decode("ascii", "replace")
        pos = end
    if damage is not None and damage not in out.skipped:
        out.skipped.append(damage)
    for msg_id, recs in rows.items():
        name, dt, _ = subs[msg_id]
        raw = b"".join(r.ljust(dt.itemsize, b"\0")[:dt.itemsize] for r in recs)  # trailing padding is not logged
        out.data[name] = np.frombuffer(raw, dtype=dt)
    return out


def _implausible(buf: bytes, pos: int, size: int, typ: int, subs: dict) -> str | None:
    if typ not in TYPES:
        return f"record type 0x{typ:02x} is not a ULog type"
    if typ == ord("D"):
        if size < 2 or pos + 5 > len(buf):
            return "a data record too short for its subscription id"
        msg_id = buf[pos + 3] | (buf[pos + 4] << 8)
        if msg_id not in subs:
            return f"no subscription found for message id {msg_id}"
        item = subs[msg_id][1].itemsize
        if not item - 64 <= size - 2 <= item:
            return f"a data record of {size - 2} bytes for {subs[msg_id][0]} ({item} bytes)"
    return None


def _resync(buf: bytes, frm: int, subs: dict) -> int | None:
    """Next offset holding a data record of a known subscription, with its right size, followed by a plausible
    record header (or the end of the file)."""
    n = len(buf)
    q = frm + 2
    while True:
        q = buf.find(b"D", q)
        if q < 0:
            return None
        r = q - 2
        if r >= frm:
            size = buf[r] | (buf[r + 1] << 8)
            if _implausible(buf, r, size, ord("D"), subs) is None:
                e = r + 3 + size
                if e == n or (e + 3 <= n and buf[e + 2] in TYPES
                              and _implausible(buf, e, buf[e] | (buf[e + 1] << 8), buf[e + 2], subs) is None):
                    return r
        q += 1


def column(arr: np.ndarray, name: str) -> np.ndarray:
    """A field by pyulog's flattened name ("x", "position[0]")."""
    if "[" in name:
        base, idx = name[:-1].split("[")
        return arr[base][:, int(idx)].astype(float)
    return arr[name].astype(float)
