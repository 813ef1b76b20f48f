"""Parameter protocol (fact sheet section 2): complete download, read, set-and-verify.

* Download: :mod:`ksbo_mav.mav.params.list_download` (re-requests missing indices while the link makes progress);
  the result is only accepted when every index 0..count-1 arrived.
* Set: the PARAM_VALUE echo is the only acknowledgement. A set is verified when an echo with the same name
  carries the requested value (within float32 rounding); a timeout is retried, a wrong value is retried once more
  and then reported as refused. Unknown names get no answer at all from an autopilot, so they are refused
  *before* sending, from the downloaded list.
* INT32 values travel in the float field either C-cast (ArduPilot) or bytewise (PX4, spec): the encoding is a
  property of the stack (:mod:`ksbo_mav.mav.params.encoding`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable

import ksbo_mav.mav.params.cache as param_cache
from ksbo_mav.errors import InputError, VehicleError, VerifyError
from ksbo_mav.mav.link import Link
from ksbo_mav.mav.params.encoding import decode, encode, same_value
from ksbo_mav.mav.params.list_download import ParamListing, download_list


@dataclass
class Param:
    name: str
    value: float  # decoded
    ptype: int
    index: int


class ParamClient:
    """Parameter service of one vehicle over ``link``; ``encoding`` is ``"c_cast"`` or ``"bytewise"``."""

    def __init__(self, link: Link, encoding: str) -> None:
        self.link = link
        self.encoding = encoding
        self.table: dict[str, Param] = {}
        self.count = 0
        self.last_download: Any = None
        self.ftp_failure = ""  # why the FTP path was not used, when it was tried

    def _id(self, name: str) -> bytes:
        return name.encode("ascii")

    # --- download -----------------------------------------------------------------------------------------
    def fetch_all(self, stall_s: float = 15.0, progress: Callable[[int, int], None] | None = None,
                  ftp: bool = False, cache: str | None = None) -> dict[str, Param]:
        """Download every parameter: with ``ftp`` first as one file over MAVLink FTP
        (:mod:`ksbo_mav.mav.params.ftp_download`), else or when that fails by the PARAM protocol
        (:func:`ksbo_mav.mav.params.list_download.download_list`: it keeps asking for missing indices while the link
        delivers, and gives up after ``stall_s`` seconds without a new one); :class:`VehicleError` unless every
        parameter arrived. ``last_download`` says how it went (``path``: "MAVLink FTP", "PARAM protocol" or
        "cache"). ``cache`` (a stack name): first ask the vehicle for its parameter hash and take the set saved
        under it (:mod:`ksbo_mav.mav.params.cache`); after a download, save the set under that hash."""
        self.ftp_failure = ""
        t0 = time.monotonic()
        h = param_cache.read_hash(self.link) if cache else None
        if h is not None and (rows := param_cache.load(cache, h)) is not None:
            self._take(rows)
            self.last_download = ParamListing(count=self.count, seconds=time.monotonic() - t0,
                                              path=f"cache, the vehicle's {param_cache.HASH_PARAM} matched")
            return self.table
        self._download(stall_s, progress, ftp)
        if h is not None and param_cache.read_hash(self.link) == h and self.count == h.count:
            rows = [(p.name, p.value, p.ptype) for p in sorted(self.table.values(), key=lambda p: p.index)]
            param_cache.save(cache, h, rows)
        return self.table

    def _download(self, stall_s: float, progress: Callable[[int, int], None] | None, ftp: bool) -> None:
        if ftp:
            from ksbo_mav.mav.params.ftp_download import download_ftp

            got, self.ftp_failure = download_ftp(self.link, progress=progress)
            if got is not None:
                self._take([(name, value, ptype) for name, (value, ptype) in got.values.items()])
                self.last_download = ParamListing(count=self.count, seconds=got.seconds, path="MAVLink FTP",
                                                  nbytes=got.nbytes)
                return
        res = download_list(self.link, stall_s=stall_s, progress=progress)
        self.last_download = res
        if not res.complete:
            raise VehicleError(f"parameter download incomplete: {len(res.values)} of {res.count or '?'} received "
                               f"in {res.seconds:.0f} s, nothing new for {stall_s:g} s (is the link dropping "
                               "most frames? see docs/links.md)")
        self.count = res.count
        self.table = {}
        for i in range(res.count):
            m = res.values[i]
            self.table[m.param_id] = Param(m.param_id, decode(m.param_value, m.param_type, self.encoding),
                                           int(m.param_type), i)

    def _take(self, rows: list[tuple[str, float, int]]) -> None:
        """The table from [(name, decoded value, MAV_PARAM_TYPE)] in index order (a file or the cache)."""
        self.table = {name: Param(name, value, ptype, i) for i, (name, value, ptype) in enumerate(rows)}
        self.count = len(self.table)

    # --- read ------------------------------------------------------------------------------------------------
    def _wait_value(self, name: str, timeout: float) -> Any:
        return self.link.wait(lambda m: m.get_type() == "PARAM_VALUE" and m.param_id == name, timeout)

    def read(self, name: str, timeout: float = 1.0, retries: int = 3) -> float:
        """Fresh read by name (PARAM_REQUEST_READ, index -1)."""
        self._known(name)
        link = self.link
        for _ in range(retries):
            link.send(link.mav.param_request_read_encode(link.target_system, link.target_component,
                                                         self._id(name), -1))
            msg = self._wait_value(name, timeout)
            if msg is not None:
                value = decode(msg.param_value, msg.param_type, self.encoding)
                self.table[name].value = value
                return value
        raise VehicleError(f"no PARAM_VALUE for {name} after {retries} read requests")

    def _known(self, name: str) -> Param:
        if name not in self.table:
            raise InputError(f"parameter {name} is not on this vehicle (not in its parameter list)")
        return self.table[name]

    # --- set --------------------------------------------------------------------------------------------------
    def set_verified(self, name: str, value: float, timeout: float = 1.0, retries: int = 3) -> float:
        """Write ``value`` and wait for the matching echo; returns the value the vehicle confirmed.

        Raises:
            InputError: unknown name, non-finite value.
            VerifyError: no echo after ``retries`` attempts, or the vehicle kept echoing another value.
        """
        p = self._known(name)
        if not math.isfinite(value):
            raise InputError(f"refusing to write a non-finite value to {name}")
        link = self.link
        wire = encode(value, p.ptype, self.encoding)
        echoed: float | None = None
        for _ in range(retries):
            link.send(link.mav.param_set_encode(link.target_system, link.target_component, self._id(name), wire,
                                                p.ptype))
            msg = self._wait_value(name, timeout)
            if msg is None:
                continue
            echoed = decode(msg.param_value, msg.param_type, self.encoding)
            if same_value(echoed, value, p.ptype):
                p.value = echoed
                return echoed
        if echoed is None:
            raise VerifyError(f"no PARAM_VALUE received for {name} after {retries} attempts")
        p.value = echoed
        raise VerifyError(f"vehicle refused {name} = {value:.9g} (it reports {echoed:.9g})")
