"""Our figure-8 recognised in a log's targets: a least-squares fit of the mission's sinusoids (phase -> start time,
constant offset -> where it was flown), or the exact start from a ksbo trial marker when the log has one."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ksbo_mav.flightlog.model import FlightLog, Segment, Track
from ksbo_mav.mav.trajectory import REF_RE, START_RE

MOVING_MPS = 0.3  # target speed above which the target is "moving"
FIT_TOL = 0.05  # a figure-8 fit is accepted when the residual RMS is below this fraction of the north amplitude
AMP_TOL = 0.1  # ... and both amplitudes are within this fraction of the mission's


@dataclass
class Fit:
    t0: float
    t_end: float
    offset: np.ndarray  # (3,) NED offset of the flown figure-8 from the mission's
    fit_rms: float
    marker: str | None
    steps: int | None = None  # from a marker
    dt_ms: int | None = None
    mission: Any = None  # the mission variant fitted: the profile's, or the same without its lead-in


def reference(mission, t: np.ndarray, offset: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Analytic (pos, vel) NED at times ``t`` (s from the mission start)."""
    t = np.asarray(t, dtype=float)
    if mission.kind != "figure8-ne":  # generic (slow) path
        pv = [mission.setpoint_at(float(x))[:2] for x in t]
        return np.array([a for a, _ in pv]).reshape(-1, 3) + offset, np.array([b for _, b in pv]).reshape(-1, 3)
    f = mission.figure8h  # Mission.setpoint_at's reference, vectorised over t
    return f.position(t) + offset, f.velocity(t)


def recognise_figure8(log: FlightLog, seg: Segment, mission) -> Fit | None:
    """The first of :func:`recognise_figure8s`, or None."""
    fits = recognise_figure8s(log, seg, mission)
    return fits[0] if fits else None


def recognise_figure8s(log: FlightLog, seg: Segment, mission) -> list[Fit]:
    """Every figure-8 of the mission inside ``seg`` (a campaign flies several in one GUIDED stretch, holding still
    between them), in time order.

    Recognised from the setpoints the vehicle received when the log has them (GUIP, trajectory_setpoint, sent
    SET_POSITION_TARGET_LOCAL_NED), else from the autopilot's target (ArduPilot's PSC target is shaped: it lags
    the setpoints by up to ~3 m in the first seconds of a trajectory, so it is the second choice).
    """
    if mission is None or mission.kind != "figure8-ne":
        return []
    for src in (log.commanded, log.target):
        if src is None:
            continue
        tg = src.window(seg.t_start, seg.t_end)
        fits = [f for run in _moving_runs(tg, mission.period) if (f := _fit_either(tg, run, log, seg, mission))]
        if fits:
            return fits
    return []


def _moving_runs(tg: Track, period: float) -> list[tuple[float, float]]:
    """Stretches (on a 10 Hz grid) of at least half a period where the horizontal target speed exceeds
    MOVING_MPS."""
    if len(tg) < 10 or tg.t[-1] - tg.t[0] < 1.0:
        return []
    grid = np.arange(tg.t[0], tg.t[-1], 0.1)
    p = np.column_stack([np.interp(grid, tg.t, tg.pos[:, k]) for k in range(2)])
    sp = np.hypot(*np.gradient(p, 0.1, axis=0).T)
    moving = sp > MOVING_MPS
    runs, i, n = [], 0, len(moving)
    while i < n:
        if not moving[i]:
            i += 1
            continue
        j = i
        while j + 1 < n and moving[j + 1]:
            j += 1
        if grid[j] - grid[i] >= 0.5 * period:
            runs.append((float(grid[i]), float(grid[j])))
        i = j + 1
    return runs


def _fit_either(tg: Track, run: tuple[float, float], log: FlightLog, seg: Segment, mission) -> Fit | None:
    """The better fit of the profile's mission and, when it has a lead-in, the same pattern started at full speed
    (the fact sheet's figure-8, flown by other tools or by ksbo before the lead-in)."""
    variants = [mission] + ([replace(mission, lead_in=0.0)] if mission.lead_in > 0 else [])
    fits = [f for m in variants if (f := _fit(tg, run, log, seg, m))]
    return min(fits, key=lambda f: f.fit_rms) if fits else None


def _fit(tg: Track, run: tuple[float, float], log: FlightLog, seg: Segment, mission) -> Fit | None:
    T, A, B = mission.period, mission.scale, mission.scale2
    w = 2 * math.pi / T
    sel = (tg.t >= run[0] - 0.2) & (tg.t <= run[1] + 0.2)
    t, pos = tg.t[sel], tg.pos[sel]
    marker = _marker_in(log, run, mission)
    if marker is not None:
        t0 = marker[0]
    else:
        steady = t >= run[0] + mission.lead_in  # the lead-in is not a sinusoid in time
        if steady.sum() < 10:
            steady[:] = True
        ts = t[steady]
        X = np.column_stack([np.sin(w * ts), np.cos(w * ts), np.ones_like(ts)])
        cn, *_ = np.linalg.lstsq(X, pos[steady, 0], rcond=None)
        if abs(math.hypot(cn[0], cn[1]) - A) > AMP_TOL * A:
            return None
        # A lead-in of L s delays the pattern by L/2 (ksbo_task.lead_in): the sinusoid's phase start is L/2 late.
        t0m = math.atan2(-cn[1], cn[0]) / w - 0.5 * mission.lead_in
        t0 = t0m + T * round((run[0] - t0m) / T)
        # refine: least squares over the run (its edges, where the setpoints start or stop moving, left out),
        # coarse then fine grid around the phase estimate
        inner = (t > run[0] + 0.3) & (t < run[1] - 0.3)
        for half, step in ((0.5, 0.01), (0.01, 0.0005)):
            cands = t0 + np.arange(-half, half + step / 2, step)
            costs = [_cost(mission, t[inner], pos[inner], c) for c in cands]
            t0 = float(cands[int(np.argmin(costs))])
    ref, _ = reference(mission, t - t0, np.zeros(3))
    offset = np.median(pos - ref, axis=0)
    res = pos - ref - offset
    fit_rms = float(np.sqrt(np.mean(np.sum(res * res, axis=1))))
    if fit_rms > FIT_TOL * A:
        return None
    X2 = np.column_stack([np.sin(2 * w * (t - t0)), np.cos(2 * w * (t - t0)), np.ones_like(t)])
    ce, *_ = np.linalg.lstsq(X2, pos[:, 1], rcond=None)
    if abs(math.hypot(ce[0], ce[1]) - B) > AMP_TOL * max(B, 0.1 * A):
        return None
    t_end = min(float(t[-1]), seg.t_end)
    if marker is not None and marker[1] is not None:
        t_end = min(t_end, t0 + marker[1] * marker[2] / 1000.0)
    return Fit(float(t0), t_end, offset, fit_rms, marker[3] if marker else None,
               marker[1] if marker else None, marker[2] if marker else None, mission)


def _cost(mission, t, pos, t0) -> float:
    ref, _ = reference(mission, t - t0, np.zeros(3))
    r = pos[:, :2] - ref[:, :2]
    r -= np.median(r, axis=0)
    return float(np.mean(np.sum(r * r, axis=1)))


def _marker_in(log: FlightLog, run: tuple[float, float], mission):
    """The trial start marker whose t0 is where this run of moving targets begins (within 1 s, plus the lead-in,
    during which the targets start from rest)."""
    for m in log.markers:
        g = START_RE.match(m.text.strip())
        if g and g.group(1) == mission.tag:
            t0 = int(g.group(2)) / 1000.0
            if run[0] - 1.0 - mission.lead_in <= t0 <= run[0] + 1.0:
                return t0, int(g.group(3)), int(g.group(4)), m.text
    return None


def _ref_marker(log: FlightLog, fit: Fit) -> float | None:
    """The campaign's reference RMS sent by the tuner right after a trial's start marker, if logged."""
    for m in log.markers:
        g = REF_RE.match(m.text.strip())
        if g and fit.t0 - 1.0 <= m.t <= fit.t_end:
            return float(g.group(1))
    return None
