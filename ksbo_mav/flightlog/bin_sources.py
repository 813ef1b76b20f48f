"""The position controller's own log across ArduPilot versions -> (actual, target) tracks in local NED metres.

* 4.2 and later: ``PSCN``/``PSCE``/``PSCD`` (``PN``/``TPN``/``VN``/``TVN``..., metres, NED);
* 4.0 and 4.1: ``PSC`` (``PX``/``TPX``/``VX``/``TVX``..., metres, north/east) with the vertical from ``PSCZ``
  (``PZ``/``TPZ``, up) when logged, else ``CTUN`` (``Alt``/``DAlt``, metres up);
* 3.x: ``NTUN`` (``PosX``/``DPosX``/``VelX``/``DVelX``..., centimetres, north/east) with ``CTUN``.

All are logged under ``LOG_BITMASK`` bit 5 (NTUN) in the position-controlled modes. The three per-axis messages
of 4.2+ are paired by their ``TimeUS`` (a damaged span can remove one of a triple).
"""

from __future__ import annotations

from functools import reduce

import numpy as np

from ksbo_mav.flightlog.model import Track

WANTED = {"PSCN", "PSCE", "PSCD", "PSC", "PSCZ", "NTUN", "CTUN"}


def _on(c, name: str, cols: list[str], t: np.ndarray, scale: float = 1.0) -> np.ndarray | None:
    """Columns of message ``name`` interpolated at times ``t`` (None when absent)."""
    if name not in c.data or len(c.data[name]) < 2 or any(col not in c.data[name].dtype.names for col in cols):
        return None
    ts = c.data[name]["TimeUS"].astype(float) * 1e-6
    order = np.argsort(ts, kind="stable")
    return np.column_stack([np.interp(t, ts[order], c.column(name, col)[order] * scale) for col in cols])


def _vertical(c, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    """(actual D, target D, actual vD) at ``t`` from PSCZ or CTUN (both log altitude, up)."""
    z = _on(c, "PSCZ", ["PZ", "TPZ", "VZ"], t)
    if z is not None:
        return -z[:, 0], -z[:, 1], -z[:, 2], "PSCZ"
    z = _on(c, "CTUN", ["Alt", "DAlt"], t)
    if z is not None:
        crt = _on(c, "CTUN", ["CRt"], t, 0.01)
        vd = -crt[:, 0] if crt is not None else np.full(t.size, np.nan)
        return -z[:, 0], -z[:, 1], vd, "CTUN"
    zero = np.zeros(t.size)
    return zero, zero, np.full(t.size, np.nan), ""


def position_tracks(c) -> tuple[Track, Track, str] | None:
    """(actual, target, the messages used) or None when the log has none of the message sets."""
    if all(k in c.data and len(c.data[k]) for k in ("PSCN", "PSCE", "PSCD")):
        times = [c.data[k]["TimeUS"] for k in ("PSCN", "PSCE", "PSCD")]
        common = reduce(np.intersect1d, times)
        idx = [np.searchsorted(ts, common) if np.all(np.diff(ts) >= 0) else
               np.array([np.flatnonzero(ts == x)[0] for x in common], dtype=int) for ts in times]
        cols = lambda pre: np.column_stack([c.column(m, f"{pre}{ax}")[i]  # noqa: E731
                                            for (m, ax), i in zip((("PSCN", "N"), ("PSCE", "E"), ("PSCD", "D")), idx)])
        t = common.astype(float) * 1e-6
        return (Track(t, cols("P"), cols("V"), "PSCN/PSCE/PSCD P* (EKF position)"),
                Track(t, cols("TP"), cols("TV"), "PSCN/PSCE/PSCD TP* (position controller target)"), "PSCN/PSCE/PSCD")
    for name, (p, tp, v, tv), scale in (("PSC", ("P", "TP", "V", "TV"), 1.0),
                                        ("NTUN", ("Pos", "DPos", "Vel", "DVel"), 0.01)):
        d = c.data.get(name)
        if d is None or len(d) < 2 or f"{p}X" not in d.dtype.names:
            continue
        t = d["TimeUS"].astype(float) * 1e-6
        ne = {k: np.column_stack([c.column(name, f"{k}X"), c.column(name, f"{k}Y")]) * scale for k in (p, tp, v, tv)}
        ad, td, vd, vsrc = _vertical(c, t)
        used = name + (f" + {vsrc}" if vsrc else " (no altitude logged: horizontal only)")
        actual = Track(t, np.column_stack([ne[p], ad]), np.column_stack([ne[v], vd]), f"{used} (EKF position)")
        target = Track(t, np.column_stack([ne[tp], td]), np.column_stack([ne[tv], np.zeros(t.size)]),
                       f"{used} (position controller target)")
        return actual, target, used
    return None
