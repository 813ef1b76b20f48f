"""Position targets a log holds in global coordinates, brought into the local NED frame of its position estimate.

ArduPilot's default telemetry streams send ``POSITION_TARGET_GLOBAL_INT`` (not the local one), so that is what a
ground station records. The local frame's origin is the log's own: ``GPS_GLOBAL_ORIGIN`` when it was recorded,
else the offset between the vehicle's ``GLOBAL_POSITION_INT`` and ``LOCAL_POSITION_NED`` at the same instants
(the median over the log). Over a figure-8's few hundred metres the flat-earth approximation is exact to
millimetres.
"""

from __future__ import annotations

import numpy as np

EARTH_R = 6_378_137.0  # WGS-84 equatorial radius (m)
#: MAV_FRAME of POSITION_TARGET_GLOBAL_INT: altitude above mean sea level, or above home.
FRAME_GLOBAL, FRAME_RELATIVE = (0, 5), (3, 6)


def origin_from_pairs(glob: np.ndarray, local: np.ndarray) -> tuple[float, float, float, float]:
    """(lat0, lon0 in degrees, amsl0, rel0 in metres) of the local frame from paired samples: ``glob`` (n, 4) rows
    of (lat deg, lon deg, alt AMSL m, alt above home m) and ``local`` (n, 3) NED metres at the same instants."""
    lat0 = float(np.median(glob[:, 0] - np.degrees(local[:, 0] / EARTH_R)))
    coslat = np.cos(np.radians(lat0))
    lon0 = float(np.median(glob[:, 1] - np.degrees(local[:, 1] / (EARTH_R * coslat))))
    amsl0 = float(np.median(glob[:, 2] + local[:, 2]))
    rel0 = float(np.median(glob[:, 3] + local[:, 2]))
    return lat0, lon0, amsl0, rel0


def to_local(lat: np.ndarray, lon: np.ndarray, alt: np.ndarray, frame: np.ndarray,
             origin: tuple[float, float, float, float]) -> np.ndarray:
    """(n, 3) NED metres of global points (degrees, metres; ``frame`` the MAV_FRAME of each altitude)."""
    lat0, lon0, amsl0, rel0 = origin
    north = np.radians(np.asarray(lat) - lat0) * EARTH_R
    east = np.radians(np.asarray(lon) - lon0) * EARTH_R * np.cos(np.radians(lat0))
    base = np.where(np.isin(frame, FRAME_RELATIVE), rel0, amsl0)
    return np.column_stack([north, east, -(np.asarray(alt) - base)])
