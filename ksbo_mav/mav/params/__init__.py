"""The vehicle's parameters: download, read and verified writes over MAVLink, and snapshots of them on disk.

The rest of the tuner uses the names exported here: :class:`ParamClient` (one vehicle's parameter service, with
its table of :class:`Param`), :data:`CAPABILITY_FTP` (the autopilot capability bit that offers the one-file
download), and the snapshot a campaign takes before its first write (:class:`Snapshot`, :func:`write_snapshot`,
:func:`load_snapshot`, :func:`write_param_files`). Failures are the package's errors: ``VehicleError`` (an
incomplete download, no answer), ``VerifyError`` (a write the vehicle did not confirm) and ``InputError`` (an
unknown name, a damaged snapshot), all from :mod:`ksbo_mav.errors`.

Modules: ``client`` (the service), ``encoding`` (values in the float field), ``list_download`` (the PARAM
protocol's full download on a lossy link), ``ftp_download`` (the parameter file over MAVLink FTP), ``cache`` (a
set kept on disk under the vehicle's hash), ``snapshot`` (the files on disk).
"""

from __future__ import annotations

from ksbo_mav.mav.params.client import Param, ParamClient
from ksbo_mav.mav.params.ftp_download import CAPABILITY_FTP
from ksbo_mav.mav.params.snapshot import Snapshot, load_snapshot, write_param_files, write_snapshot

__all__ = ["CAPABILITY_FTP", "Param", "ParamClient", "Snapshot", "load_snapshot", "write_param_files",
           "write_snapshot"]
