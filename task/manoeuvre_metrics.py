"""Figures of the validation manoeuvres, from arrays of time and position: what a live flight and a flight log share.

Positions are local NED (m), times in seconds, one row per telemetry sample. Each function returns a dict of plain
floats (NaN where the figure does not exist, e.g. a step that never settled) under fixed names:

* :func:`step_response` — one position step from ``start`` to ``target``: ``rise_s`` (10 % to 90 % of the step,
  measured along the step's direction), ``overshoot_pct`` (how far past the target along that direction, in % of the
  step; 0 when it never passed), ``settle_s`` (from the step's start until the vehicle stays within the settling
  band of the target: ``max(settle_fraction * step size, settle_floor_m)`` of 3-D distance; NaN when it is still
  outside at the last sample).
* :func:`hold_drift` — a position hold: ``rms_m`` and ``max_m`` of the horizontal distance from the hold point, and
  ``vert_rms_m`` of the vertical one.
* :func:`mission_tracking` — a mission flown along straight legs through ``waypoints``: ``xtrack_rms_m`` and
  ``xtrack_max_m`` (horizontal distance to the leg being flown), ``vert_rms_m``, per corner ``overshoot_m`` (how far
  the vehicle went on in the incoming leg's direction past the corner) and ``settle_s`` (from passing the corner
  until it stays within ``settle_band_m`` of the outgoing leg; both judged over the first half of that leg, so the
  next corner's own rounding does not count against this one), the same at the final waypoint, and ``time_s``
  (from the first sample to the first one within ``arrive_m`` of the final waypoint on the last leg).

A sample belongs to leg k until it crosses the bisector of the corner at the leg's end (the line through the
corner that splits the angle between the two legs): corner-cutting paths are then judged against the leg they leave
until half-way round the turn, and against the next one after.
"""

from __future__ import annotations

import math

import numpy as np

NAN = math.nan


def _settle_time(t: np.ndarray, outside: np.ndarray, t_start: float) -> float:
    """Seconds from ``t_start`` to the first sample after which no sample is ``outside``; NaN when the last is."""
    if not len(t) or outside[-1]:
        return NAN
    bad = np.flatnonzero(outside)
    i = 0 if not len(bad) else int(bad[-1]) + 1
    return float(t[i] - t_start)


def step_response(t: np.ndarray, pos: np.ndarray, start: np.ndarray, target: np.ndarray, t_step: float, *,
                  settle_fraction: float = 0.05, settle_floor_m: float = 0.1) -> dict[str, float]:
    """Rise time, overshoot and settling time of one step; ``t`` (n,), ``pos`` (n, 3) from ``t_step`` (the time the
    new target was sent) up to the next step's start."""
    t, pos = np.asarray(t, float), np.asarray(pos, float).reshape(-1, 3)
    start, target = np.asarray(start, float), np.asarray(target, float)
    delta = target - start
    size = float(np.linalg.norm(delta))
    out = {"size_m": size, "rise_s": NAN, "overshoot_pct": NAN, "settle_s": NAN}
    sel = t >= t_step
    t, pos = t[sel], pos[sel]
    if size <= 0.0 or not len(t):
        return out
    frac = (pos - start) @ (delta / size) / size
    i10, i90 = np.flatnonzero(frac >= 0.1), np.flatnonzero(frac >= 0.9)
    if len(i10) and len(i90):
        out["rise_s"] = float(t[i90[0]] - t[i10[0]])
    out["overshoot_pct"] = float(max(0.0, float(frac.max()) - 1.0) * 100.0)
    band = max(settle_fraction * size, settle_floor_m)
    out["settle_s"] = _settle_time(t, np.linalg.norm(pos - target, axis=1) > band, t_step)
    return out


def hold_drift(pos: np.ndarray, hold_point: np.ndarray) -> dict[str, float]:
    """Drift of a position hold from ``hold_point`` (3,): horizontal RMS and max, vertical RMS; ``pos`` (n, 3)."""
    pos = np.asarray(pos, float).reshape(-1, 3)
    if not len(pos):
        return {"rms_m": NAN, "max_m": NAN, "vert_rms_m": NAN}
    d = pos - np.asarray(hold_point, float)
    h = np.hypot(d[:, 0], d[:, 1])
    return {"rms_m": float(np.sqrt(np.mean(h * h))), "max_m": float(h.max()),
            "vert_rms_m": float(np.sqrt(np.mean(d[:, 2] ** 2)))}


def assign_legs(pos: np.ndarray, waypoints: np.ndarray) -> np.ndarray:
    """(n,) index of the leg (0 .. m-2) each sample of ``pos`` (n, 3) is flying, through ``waypoints`` (m, 3), in
    time order: a sample moves on to the next leg once it has crossed the bisector of the corner between them."""
    pos, wp = np.asarray(pos, float).reshape(-1, 3), np.asarray(waypoints, float).reshape(-1, 3)
    legs = len(wp) - 1
    out = np.zeros(len(pos), dtype=int)
    k = 0
    for i, p in enumerate(pos[:, :2]):
        while k < legs - 1:
            u1, u2 = _unit(wp[k + 1] - wp[k]), _unit(wp[k + 2] - wp[k + 1])
            if float((p - wp[k + 1, :2]) @ (u1 + u2)) > 0.0:
                k += 1
            else:
                break
        out[i] = k
    return out


def _unit(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v[:2], float)
    n = float(np.hypot(v[0], v[1]))
    return v / n if n > 0 else v


def cross_track(pos: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(n,) horizontal distance of each of ``pos`` (n, 3) from the segment a-b."""
    p = np.asarray(pos, float).reshape(-1, 3)[:, :2]
    a2, b2 = np.asarray(a, float)[:2], np.asarray(b, float)[:2]
    ab = b2 - a2
    L2 = float(ab @ ab)
    s = np.clip((p - a2) @ ab / L2, 0.0, 1.0) if L2 > 0 else np.zeros(len(p))
    return np.linalg.norm(p - (a2 + s[:, None] * ab), axis=1)


def mission_tracking(t: np.ndarray, pos: np.ndarray, waypoints: np.ndarray, *, settle_band_m: float = 0.2,
                     arrive_m: float = 0.5) -> dict[str, float]:
    """Cross-track, corner and completion figures of a mission through ``waypoints`` (m, 3) NED, flown from the
    first; ``t`` (n,), ``pos`` (n, 3) from the mission's start. Corners are numbered 1 .. m-2; the final waypoint's
    figures are ``final_overshoot_m`` and ``final_settle_s``."""
    t, pos = np.asarray(t, float), np.asarray(pos, float).reshape(-1, 3)
    wp = np.asarray(waypoints, float).reshape(-1, 3)
    m = len(wp)
    out: dict[str, float] = {}
    if m < 2 or not len(t):
        return {"xtrack_rms_m": NAN, "xtrack_max_m": NAN, "vert_rms_m": NAN, "time_s": NAN}
    leg = assign_legs(pos, wp)
    xt = np.empty(len(t))
    vert = np.empty(len(t))
    for k in range(m - 1):
        sel = leg == k
        xt[sel] = cross_track(pos[sel], wp[k], wp[k + 1])
        vert[sel] = pos[sel, 2] - np.interp(_along(pos[sel], wp[k], wp[k + 1]), [0.0, 1.0], [wp[k, 2], wp[k + 1, 2]])
    out["xtrack_rms_m"] = float(np.sqrt(np.mean(xt * xt)))
    out["xtrack_max_m"] = float(xt.max())
    out["vert_rms_m"] = float(np.sqrt(np.mean(vert * vert)))
    for c in range(1, m - 1):  # corner c joins leg c-1 and leg c
        after = np.flatnonzero(leg == c)
        u_in = _unit(wp[c] - wp[c - 1])
        if not len(after):
            out[f"corner{c}_overshoot_m"], out[f"corner{c}_settle_s"] = NAN, NAN
            continue
        half = _along(pos[after], wp[c], wp[c + 1]) <= 0.5
        first_half = after[: int(np.argmin(half))] if not half.all() else after  # until it first passes half-way
        if not len(first_half):
            first_half = after[:1]
        past = (pos[first_half, :2] - wp[c, :2]) @ u_in
        out[f"corner{c}_overshoot_m"] = float(max(0.0, float(past.max())))
        out[f"corner{c}_settle_s"] = _settle_time(t[first_half], xt[first_half] > settle_band_m,
                                                  float(t[after[0]]))
    last = np.flatnonzero(leg == m - 2)
    u_last = _unit(wp[-1] - wp[-2])
    beyond = (pos[last, :2] - wp[-1, :2]) @ u_last
    out["final_overshoot_m"] = float(max(0.0, float(beyond.max()))) if len(last) else NAN
    dist = np.linalg.norm(pos[last] - wp[-1], axis=1)
    crossed = last[beyond >= 0.0] if len(last) else last
    arrived = last[dist <= arrive_m]
    out["final_settle_s"] = NAN
    if len(crossed):
        i0 = int(crossed[0])
        tail = np.arange(i0, len(t))
        out["final_settle_s"] = _settle_time(t[tail], np.linalg.norm(pos[tail] - wp[-1], axis=1) > settle_band_m,
                                             float(t[i0]))
    out["time_s"] = float(t[arrived[0]] - t[0]) if len(arrived) else NAN
    corners = [out[f"corner{c}_overshoot_m"] for c in range(1, m - 1)]
    settles = [out[f"corner{c}_settle_s"] for c in range(1, m - 1)]
    out["corner_overshoot_m_mean"] = _mean(corners)
    out["corner_settle_s_mean"] = _mean(settles)
    out["corners_unsettled"] = float(sum(1 for s in settles if not math.isfinite(s)))
    return out


def _along(pos: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(n,) horizontal progress of ``pos`` along a-b as a fraction of its length (unclipped)."""
    ab = np.asarray(b, float)[:2] - np.asarray(a, float)[:2]
    L2 = float(ab @ ab)
    if L2 <= 0:
        return np.zeros(len(pos))
    return (np.asarray(pos, float).reshape(-1, 3)[:, :2] - np.asarray(a, float)[:2]) @ ab / L2


def _mean(values: list[float]) -> float:
    finite = [v for v in values if math.isfinite(v)]
    return float(np.mean(finite)) if finite else NAN
