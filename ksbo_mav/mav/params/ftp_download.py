"""The whole parameter set as one file over MAVLink FTP (``@PARAM/param.pck``), where the autopilot serves it.

ArduPilot (>= 4.1) packs every parameter into a virtual file that a ground station reads in bursts of FTP
``ReadFile`` replies; on a slow link that is far fewer frames than one ``PARAM_VALUE`` per parameter, and lost
replies are re-read by offset rather than by name. pymavlink's :class:`~pymavlink.mavftp.MAVFTP` client does the
protocol (sessions, bursts, gap re-reads) and decodes the packed file; this module only gives it our
:class:`~ksbo_mav.mav.link.Link` to talk through and keeps the parameter types (the packed type codes map to
``MAV_PARAM_TYPE``) so that later writes use them. Anything the autopilot does not serve (no FTP capability, a
NACK, a file that does not decode, silence) is a ``None`` with the reason: the caller falls back to the PARAM
protocol.
"""

from __future__ import annotations

import logging
import time
from collections import deque
from dataclasses import dataclass
from typing import Any, Callable

from ksbo_mav.mav.link import Link
from ksbo_mav.mav.wire import mavlink

PARAM_FILE = "@PARAM/param.pck"
CAPABILITY_FTP = mavlink.MAV_PROTOCOL_CAPABILITY_FTP
#: param.pck type codes -> MAV_PARAM_TYPE
PCK_TYPES = {1: mavlink.MAV_PARAM_TYPE_INT8, 2: mavlink.MAV_PARAM_TYPE_INT16, 3: mavlink.MAV_PARAM_TYPE_INT32,
             4: mavlink.MAV_PARAM_TYPE_REAL32}


@dataclass
class FtpParams:
    """The decoded file: ``values[name] = (value, MAV_PARAM_TYPE)`` in the file's order."""

    values: dict[str, tuple[float, int]]
    seconds: float
    nbytes: int


class FtpPort:
    """What :class:`~pymavlink.mavftp.MAVFTP` needs of a connection (``mav`` to send, ``recv_match`` for the
    vehicle's FILE_TRANSFER_PROTOCOL replies), on top of our link so that its pump, heartbeats and tlog go on."""

    def __init__(self, link: Link) -> None:
        self.link, self.mav = link, link.mav
        self.source_system, self.source_component = link.mav.srcSystem, link.mav.srcComponent  # replies to us
        self.replies: deque[Any] = deque()
        link.handlers.append(self._collect)

    def _collect(self, msg: Any) -> None:
        if msg.get_type() == "FILE_TRANSFER_PROTOCOL" and msg.get_srcSystem() == self.link.target_system:
            self.replies.append(msg)

    def recv_match(self, type: Any = None, timeout: float | None = None, blocking: bool = False,  # noqa: A002
                   **_: Any) -> Any:
        deadline = time.monotonic() + (timeout if timeout is not None else (1.0 if blocking else 0.0))
        while not self.replies:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return None
            self.link.pump(min(remaining, 0.05))
        return self.replies.popleft()

    def close(self) -> None:
        if self._collect in self.link.handlers:
            self.link.handlers.remove(self._collect)


def download_ftp(link: Link, timeout_s: float = 60.0, burst: int = 80,
                 progress: Callable[[int, int], None] | None = None) -> tuple[FtpParams | None, str]:
    """``(params, "")`` or ``(None, why)``. ``burst`` is the bytes per FTP reply asked for (at most 239; 80, as
    MAVProxy uses, keeps each reply a small frame on a radio); ``timeout_s`` bounds the whole transfer."""
    from pymavlink import mavftp

    root = logging.getLogger()
    level = root.level
    root.setLevel(max(level, logging.ERROR + 1))  # MAVFTP logs each step (and a size estimate's miss) to the root
    port = FtpPort(link)
    got: list[bytes | None] = []
    t0 = time.monotonic()
    try:
        settings = mavftp.MAVFTPSettings([("debug", int, 0), ("pkt_loss_tx", int, 0), ("pkt_loss_rx", int, 0),
                                          ("max_backlog", int, 5), ("burst_read_size", int, burst),
                                          ("write_size", int, 80), ("write_qsize", int, 5),
                                          ("idle_detection_time", float, 3.7), ("read_retry_time", float, 1.0),
                                          ("retry_time", float, 0.5)])
        ftp = mavftp.MAVFTP(port, link.target_system, link.target_component, settings=settings)
        ret = ftp.cmd_get([PARAM_FILE], callback=lambda fh: got.append(fh.read() if fh else None),
                          progress_callback=(lambda frac: progress(int(1000 * (frac or 0)), 1000))
                          if progress else None)
        if ret.error_code == mavftp.FtpError.Success:
            ret = ftp.process_ftp_reply("OpenFileRO", timeout=timeout_s)
        if not got or got[0] is None:
            return None, f"MAVLink FTP read of {PARAM_FILE} failed ({ret.error_code.name})"
        data = got[0]
        pdata = mavftp.MAVFTP.ftp_param_decode(data)
        if pdata is None:
            return None, f"{PARAM_FILE} ({len(data)} bytes) did not decode"
        values = {name.decode(): (float(value), PCK_TYPES[ptype]) for name, value, ptype in pdata.params}
        return FtpParams(values, time.monotonic() - t0, len(data)), ""
    except Exception as exc:  # the library's failures (timeouts, asserts) mean "not this path", never a crash
        return None, f"MAVLink FTP failed: {exc.__class__.__name__}: {exc}"
    finally:
        port.close()
        root.setLevel(level)
