"""Global positions (latitude, longitude, altitude) to the vehicle's local NED frame, with the log's own origin.

The origin is the log's ``GPS_GLOBAL_ORIGIN`` when it has one; otherwise it is found from the vehicle's own pairs
of ``GLOBAL_POSITION_INT`` and ``LOCAL_POSITION_NED`` (the same estimator state in both frames). Flat earth about
the origin: exact to millimetres over the few hundred metres a position-loop flight covers.
"""

from __future__ import annotations

import math

import numpy as np

R_EARTH = 6_378_137.0  # WGS-84 equatorial radius (m)
AMSL_FRAMES = {0, 5}  # MAV_FRAME_GLOBAL, MAV_FRAME_GLOBAL_INT: altitude above mean sea level
REL_FRAMES = {3, 6}  # MAV_FRAME_GLOBAL_RELATIVE_ALT(_INT): altitude above home
TERRAIN_FRAMES = {10, 11}


class Origin:
    """Maps (lat deg, lon deg, alt m, MAVLink frame) to local NED (m)."""

    def __init__(self, lat0: float, lon0: float, d_amsl: float | None, d_rel: float | None, source: str) -> None:
        self.lat0, self.lon0, self.d_amsl, self.d_rel, self.source = lat0, lon0, d_amsl, d_rel, source

    def to_ned(self, lat: np.ndarray, lon: np.ndarray, alt: np.ndarray, frame: np.ndarray) -> np.ndarray:
        lat, lon, alt, frame = (np.asarray(x, dtype=float) for x in (lat, lon, alt, frame))
        n = np.radians(lat - self.lat0) * R_EARTH
        e = np.radians(lon - self.lon0) * R_EARTH * math.cos(math.radians(self.lat0))
        d = np.full_like(n, np.nan)
        amsl = np.isin(frame, list(AMSL_FRAMES))
        rel = np.isin(frame, list(REL_FRAMES | TERRAIN_FRAMES))
        if self.d_amsl is not None:
            d[amsl] = self.d_amsl - alt[amsl]
        if self.d_rel is not None:
            d[rel] = self.d_rel - alt[rel]
        return np.column_stack([n, e, d])


def origin_from_message(lat_e7: int, lon_e7: int, alt_mm: int, pairs: "Origin | None") -> Origin:
    """The origin a GPS_GLOBAL_ORIGIN states (altitude AMSL); the home offset of relative altitudes from pairs."""
    lat0, lon0, alt0 = lat_e7 * 1e-7, lon_e7 * 1e-7, alt_mm * 1e-3
    return Origin(lat0, lon0, alt0, pairs.d_rel if pairs else None, "GPS_GLOBAL_ORIGIN")


def origin_from_pairs(glob: np.ndarray, local) -> Origin | None:
    """``glob`` rows (t s, lat deg, lon deg, alt AMSL m, relative alt m); ``local`` a Track of LOCAL_POSITION_NED.
    None without enough overlapping samples."""
    if glob is None or len(glob) == 0 or local is None or len(local) < 2:
        return None
    pos = local.at(glob[:, 0], max_gap=0.3)
    ok = np.all(np.isfinite(pos), axis=1)
    if ok.sum() < 3:
        return None
    g, p = glob[ok], pos[ok]
    lat0 = float(np.median(g[:, 1] - np.degrees(p[:, 0] / R_EARTH)))
    coslat = math.cos(math.radians(lat0))
    lon0 = float(np.median(g[:, 2] - np.degrees(p[:, 1] / (R_EARTH * coslat))))
    d_amsl = float(np.median(p[:, 2] + g[:, 3]))
    d_rel = float(np.median(p[:, 2] + g[:, 4]))
    return Origin(lat0, lon0, d_amsl, d_rel, "GLOBAL_POSITION_INT/LOCAL_POSITION_NED pairs")
