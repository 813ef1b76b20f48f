"""Files on the vehicle over MAVLink FTP: write one, remove one, list a directory.

pymavlink's :class:`~pymavlink.mavftp.MAVFTP` does the protocol (sessions, write bursts, acknowledgements); it
talks through :class:`~ksbo_mav.mav.params.ftp_download.FtpPort`, so our link's pump, heartbeats and tlog go on
during a transfer. Every failure is a :class:`~ksbo_mav.errors.VehicleError` with one line saying which file and
why; MAVFTP's own logging (one line per step, to the root logger) is silenced while it runs.
"""

from __future__ import annotations

import contextlib
import io
import logging
from collections.abc import Iterator
from typing import Any

from ksbo_mav.errors import VehicleError
from ksbo_mav.mav.link import Link
from ksbo_mav.mav.params.ftp_download import FtpPort


#: Seconds of silence after which a request that has no positive completion in MAVFTP (a listing or removal the
#: vehicle refused, a removal) counts as answered: MAVFTP's own 3.7 s made every guard install and removal wait
#: seconds for nothing. Callers on a slow link pass more (three round trips, as the command waits).
QUIET_S = 1.5


@contextlib.contextmanager
def _session(link: Link, quiet_s: float = QUIET_S) -> Iterator[Any]:
    from pymavlink import mavftp

    root = logging.getLogger()
    level = root.level
    root.setLevel(max(level, logging.ERROR + 1))
    port = FtpPort(link)
    try:
        # write_size 80 and a queue of 5, as MAVProxy: small frames that a radio carries.
        settings = mavftp.MAVFTPSettings([("debug", int, 0), ("pkt_loss_tx", int, 0), ("pkt_loss_rx", int, 0),
                                          ("max_backlog", int, 5), ("burst_read_size", int, 80),
                                          ("write_size", int, 80), ("write_qsize", int, 5),
                                          ("idle_detection_time", float, max(QUIET_S, quiet_s)),
                                          ("read_retry_time", float, 1.0),
                                          ("retry_time", float, 0.5)])
        yield mavftp.MAVFTP(port, link.target_system, link.target_component, settings=settings)
    finally:
        port.close()
        root.setLevel(level)


def _ok(ret: Any) -> bool:
    from pymavlink import mavftp

    return ret.error_code == mavftp.FtpError.Success


def put_file(link: Link, remote_path: str, data: bytes, timeout_s: float = 30.0, quiet_s: float = QUIET_S) -> None:
    """Write ``data`` to ``remote_path`` on the vehicle (an existing file is replaced)."""
    done: list[bool] = []
    try:
        with _session(link, quiet_s) as ftp:
            ret = ftp.cmd_put(["-", remote_path], fh=io.BytesIO(data), callback=lambda fh: done.append(True))
            if _ok(ret):  # "put": MAVFTP ends the wait at the upload's last acknowledged write, not at silence
                ret = ftp.process_ftp_reply("put", timeout=max(timeout_s, 2 * quiet_s))
    except Exception as exc:  # noqa: BLE001 - the library's own failures (asserts, timeouts): one line
        raise VehicleError(f"MAVLink FTP write of {remote_path} failed: {exc.__class__.__name__}: {exc}") from None
    if not done:
        raise VehicleError(f"MAVLink FTP write of {remote_path} ({len(data)} bytes) did not complete "
                           f"({ret.error_code.name})")


def remove_file(link: Link, remote_path: str, quiet_s: float = QUIET_S) -> bool:
    """Remove ``remote_path``; False when the vehicle says there is no such file (ArduPilot answers a missing
    file with its errno, FailErrno)."""
    from pymavlink import mavftp

    try:
        with _session(link, quiet_s) as ftp:
            ret = ftp.cmd_rm([remote_path])
    except Exception as exc:  # noqa: BLE001
        raise VehicleError(f"MAVLink FTP remove of {remote_path} failed: {exc.__class__.__name__}: {exc}") from None
    if _ok(ret):
        return True
    if ret.error_code in (mavftp.FtpError.FileNotFound, mavftp.FtpError.FailErrno):
        return False
    raise VehicleError(f"MAVLink FTP remove of {remote_path} failed ({ret.error_code.name})")


def list_dir(link: Link, remote_dir: str, quiet_s: float = QUIET_S) -> list[str] | None:
    """Names in ``remote_dir`` (directories end in ``/``), or None when it does not exist."""
    try:
        with _session(link, quiet_s) as ftp:
            ret = ftp.cmd_list([remote_dir])
            entries = list(ftp.list_result) if _ok(ret) else None
    except Exception as exc:  # noqa: BLE001
        raise VehicleError(f"MAVLink FTP listing of {remote_dir} failed: {exc.__class__.__name__}: {exc}") from None
    if entries is None:
        return None
    return [e.name + ("/" if e.is_dir else "") for e in entries if e.name not in (".", "..")]
