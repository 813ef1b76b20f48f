"""The one place that imports pymavlink, so MAVLink 2 framing is switched on before anything else loads it.

pymavlink picks v1 or v2 framing from the ``MAVLINK20`` environment variable at *import* time (fact sheet 5.2);
every module of this package imports ``mavutil``/``mavlink`` from here instead of from pymavlink directly.
"""

from __future__ import annotations

import os

os.environ["MAVLINK20"] = "1"

from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import ardupilotmega as mavlink  # noqa: E402

__all__ = ["mavutil", "mavlink"]
