"""Segments where the vehicle tracked position targets, our figure-8 recognised in them, and their scores.

A *segment* is a stretch of the log in a target-tracking mode (ArduCopter GUIDED/AUTO, PX4 OFFBOARD/AUTO.MISSION,
armed) with the autopilot's target logged. In each segment:

* errors against the autopilot's own logged target, at the target's sample times (position interpolated there):
  horizontal ``hypot(dN, dE)`` and vertical ``|dD|``, RMS and max;
* every figure-8 of the profile's mission (a campaign flies several in one GUIDED stretch, holding still between
  them), where the targets follow it: recognised by a least-squares fit of the mission's sinusoids (phase -> start
  time ``t0``, constant offset -> where it was flown), or taken exactly from a ksbo trial marker when the log has
  one. Then per lap: errors against the target and against the analytic
  reference ``Mission.setpoint_at(t - t0) + offset`` at the position's own sample times, so the two can be compared;
  and, when at least the mission's laps were flown, the profile's score ``P`` from
  :meth:`ksbo_mav.mav.mission.Mission.score` on the position resampled at the mission's control instants
  ``t0 + (k+1) dt`` (as the live tuner pairs telemetry with setpoints).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.flightlog.model import FlightLog, Track

MOVING_MPS = 0.3  # target speed above which the target is "moving"
FIT_TOL = 0.05  # a figure-8 fit is accepted when the residual RMS is below this fraction of the north amplitude
AMP_TOL = 0.1  # ... and both amplitudes are within this fraction of the mission's
START_RE = re.compile(r"^ksbo (f8h?) start t0=(\d+) n=(\d+) dt=(\d+) w=(\d+)")
REF_RE = re.compile(r"^ksbo f8h? ref rms=([0-9.eE+-]+)")


@dataclass
class Segment:
    index: int  # 1-based
    t_start: float
    t_end: float
    mode: str
    open_end: bool  # the log ends while still in this segment


def find_segments(log: FlightLog, min_duration: float = 2.0) -> list[Segment]:
    """Tracking-mode stretches that hold at least a few target samples. Without any mode information (a tlog
    without HEARTBEATs) the whole stretch with targets counts as one segment."""
    t_lo, t_hi = float(log.actual.t[0]), float(log.actual.t[-1])
    if log.target is None or len(log.target) == 0:
        return []
    spans: list[tuple[float, float, str, bool]] = []
    if not log.modes:
        spans.append((float(log.target.t[0]), float(log.target.t[-1]), "unknown mode", True))
    else:
        for i, m in enumerate(log.modes):
            if not m.tracking:
                continue
            end = log.modes[i + 1].t if i + 1 < len(log.modes) else math.inf
            spans.append((m.t, end, m.name, i + 1 == len(log.modes)))
    out = []
    for a, b, name, last in spans:
        a, b = max(a, t_lo), min(b, t_hi)
        if b - a < min_duration:
            continue
        n = int(np.sum((log.target.t >= a) & (log.target.t <= b)))
        if n < 10:
            continue
        out.append(Segment(len(out) + 1, a, b, name, last))
    return out


def error_stats(err: np.ndarray) -> dict[str, Any]:
    """RMS / max of horizontal and vertical error of (n, 3) NED errors (NaN rows ignored)."""
    err = err[np.all(np.isfinite(err), axis=1)]
    if len(err) == 0:
        return {"n": 0, "h_rms_m": None, "h_max_m": None, "v_rms_m": None, "v_max_m": None, "rms_3d_m": None}
    h = np.hypot(err[:, 0], err[:, 1])
    v = np.abs(err[:, 2])
    return {"n": int(len(err)), "h_rms_m": float(np.sqrt(np.mean(h * h))), "h_max_m": float(h.max()),
            "v_rms_m": float(np.sqrt(np.mean(v * v))), "v_max_m": float(v.max()),
            "rms_3d_m": float(np.sqrt(np.mean(np.sum(err * err, axis=1))))}


def vs_target(log: FlightLog, t0: float, t1: float) -> tuple[np.ndarray, np.ndarray]:
    """(times, NED errors actual - target) at the target's samples in [t0, t1)."""
    tg = log.target.window(t0, t1)
    sel = tg.t < t1
    t = tg.t[sel]
    return t, log.actual.at(t) - tg.pos[sel]


@dataclass
class Fit:
    t0: float
    t_end: float
    offset: np.ndarray  # (3,) NED offset of the flown figure-8 from the mission's
    fit_rms: float
    marker: str | None
    steps: int | None = None  # from a marker
    dt_ms: int | None = None


def reference(mission, t: np.ndarray, offset: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Analytic (pos, vel) NED at times ``t`` (s from the mission start)."""
    t = np.asarray(t, dtype=float)
    p0, v0, _ = mission.setpoint_at(0.0)
    if mission.kind != "figure8-ne":  # generic (slow) path
        pv = [mission.setpoint_at(float(x))[:2] for x in t]
        return np.array([a for a, _ in pv]).reshape(-1, 3) + offset, np.array([b for _, b in pv]).reshape(-1, 3)
    # Mission.setpoint_at, vectorised (checked against it in the tests)
    w = 2 * math.pi / mission.period
    A, B = mission.scale, mission.scale2
    pos = np.column_stack([A * np.sin(w * t), B * np.sin(2 * w * t), np.full_like(t, p0[2])])
    vel = np.column_stack([A * w * np.cos(w * t), 2 * B * w * np.cos(2 * w * t), np.zeros_like(t)])
    return pos + offset, vel


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
        fits = [f for run in _moving_runs(tg, mission.period) if (f := _fit(tg, run, log, seg, mission))]
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


def _fit(tg: Track, run: tuple[float, float], log: FlightLog, seg: Segment, mission) -> Fit | None:
    T, A, B = mission.period, mission.scale, mission.scale2
    w = 2 * math.pi / T
    sel = (tg.t >= run[0] - 0.2) & (tg.t <= run[1] + 0.2)
    t, pos = tg.t[sel], tg.pos[sel]
    marker = _marker_in(log, run, mission)
    if marker is not None:
        t0 = marker[0]
    else:
        X = np.column_stack([np.sin(w * t), np.cos(w * t), np.ones_like(t)])
        cn, *_ = np.linalg.lstsq(X, pos[:, 0], rcond=None)
        if abs(math.hypot(cn[0], cn[1]) - A) > AMP_TOL * A:
            return None
        t0m = math.atan2(-cn[1], cn[0]) / w
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
               marker[1] if marker else None, marker[2] if marker else None)


def _cost(mission, t, pos, t0) -> float:
    ref, _ = reference(mission, t - t0, np.zeros(3))
    r = pos[:, :2] - ref[:, :2]
    r -= np.median(r, axis=0)
    return float(np.mean(np.sum(r * r, axis=1)))


def _marker_in(log: FlightLog, run: tuple[float, float], mission):
    """The trial start marker whose t0 is where this run of moving targets begins (within 1 s)."""
    for m in log.markers:
        g = START_RE.match(m.text)
        if g and g.group(1) == mission.tag:
            t0 = int(g.group(2)) / 1000.0
            if run[0] - 1.0 <= t0 <= run[0] + 1.0:
                return t0, int(g.group(3)), int(g.group(4)), m.text
    return None


def _ref_marker(log: FlightLog, fit: Fit) -> float | None:
    """The campaign's reference RMS sent by the tuner right after a trial's start marker, if logged."""
    for m in log.markers:
        g = REF_RE.match(m.text)
        if g and fit.t0 - 1.0 <= m.t <= fit.t_end:
            return float(g.group(1))
    return None


def mission_score(log: FlightLog, fit: Fit, mission, rms_ref: float | None = None) -> dict[str, Any]:
    """The profile's score (``Mission.score``) of the figure-8, or the reason there is none. ``rms_ref`` (the
    campaign's baseline lap-2 RMS; default: the trial's ``ref rms=`` marker when logged) makes P comparable with
    the live score; without one a flight is its own reference."""
    from ksbo_mav.objective import Trajectory

    n, dt = mission.steps, mission.dt
    if fit.steps is not None and (fit.steps, fit.dt_ms) != (mission.steps, mission.dt_ms):
        return {"P": None, "reason": f"the trial ({fit.steps} steps of {fit.dt_ms} ms) is not the profile's "
                                     f"mission ({mission.steps} of {mission.dt_ms} ms)"}
    laps_flown = (fit.t_end - fit.t0) / mission.period
    # the run of moving setpoints ends at the last logged setpoint (PX4 logs trajectory_setpoint at ~5 Hz)
    if fit.t_end - fit.t0 < n * dt - max(2 * dt, 0.5):
        return {"P": None, "reason": f"{laps_flown:.2f} of the mission's {mission.laps} laps were flown"}
    tk = fit.t0 + (np.arange(n) + 1) * dt
    pos = log.actual.at(tk)
    vel = log.actual.vel_at(tk)
    ref_p, ref_v = reference(mission, tk - fit.t0, fit.offset)
    ok = np.all(np.isfinite(pos), axis=1)
    L = int(np.argmin(ok)) if not ok.all() else n
    if not np.all(np.isfinite(vel[:L])):
        vel[:L] = np.gradient(pos[:L], dt, axis=0) if L > 1 else 0.0
    states = np.column_stack([pos[:, 0], vel[:, 0], pos[:, 1], vel[:, 1], -pos[:, 2], -vel[:, 2]])[:L]
    refs = np.column_stack([ref_p[:, 0], ref_v[:, 0], ref_p[:, 1], ref_v[:, 1], -ref_p[:, 2], -ref_v[:, 2]])[:L]
    traj = Trajectory(t=(np.arange(L) + 1) * dt, steps=np.arange(L), states=states, refs=refs, inputs=None, L=L,
                      source=log.fmt)
    if rms_ref is None:
        rms_ref = _ref_marker(log, fit)
    s = mission.score(traj, rms_ref=rms_ref) if rms_ref is not None else mission.score(traj)
    return {"P": s["P"], **{k: v for k, v in s.items() if k != "P"}}


def analyse(log: FlightLog, mission=None, profile_name: str | None = None, partial: bool = False,
            only: int | None = None, rms_ref: float | None = None) -> dict[str, Any]:
    """Every segment's scores as a JSON-friendly dict (see module doc). Raises :class:`InputError` when there is
    nothing to score, or when the log is cut inside a segment (unless ``partial``)."""
    segs = find_segments(log)
    if not segs:
        seen = ", ".join(dict.fromkeys(m.name for m in log.modes)) or "none logged"
        what = "no position targets at all" if log.target is None else f"modes seen: {seen}"
        raise InputError(f"{log.path}: no segment where the vehicle tracked position targets in a guided/auto/"
                         f"offboard mode ({what})")
    if log.truncated_at is None and log.fmt in ("bin", "ulg") and segs[-1].open_end:
        # An onboard log closes after disarm; one that stops in a tracking mode was cut on a message boundary.
        log.truncated_at = float(log.actual.t[-1])
        log.info["truncated"] = (f"it stops at t={log.truncated_at:.1f} s in {segs[-1].mode}, before any mode "
                                 f"change or disarm")
    if log.truncated_at is not None:
        cut = [s for s in segs if s.open_end]
        msg = f"{log.path} is truncated ({log.info.get('truncated', '')})"
        if cut and not partial:
            raise InputError(f"{msg}, inside segment {cut[-1].index} ({cut[-1].mode} from t={cut[-1].t_start:.1f} s)"
                             f": its end is missing; pass --partial to score what is there")
        log.warnings.append(msg + ("; the last segment is incomplete" if cut
                                   else "; every segment ended before the cut"))
    if only is not None:
        if not 1 <= only <= len(segs):
            raise InputError(f"{log.path}: --segment {only} does not exist (segments 1..{len(segs)})")
        segs = [segs[only - 1]]
    out = []
    for seg in segs:
        t, e = vs_target(log, seg.t_start, seg.t_end + 1e-9)
        entry: dict[str, Any] = {"segment": seg.index, "mode": seg.mode, "t_start_s": seg.t_start,
                                 "t_end_s": seg.t_end, "duration_s": seg.t_end - seg.t_start,
                                 "vs_target": error_stats(e), "figure8": None}
        entry["figure8s"] = [figure8_entry(log, fit, mission, profile_name, rms_ref)
                             for fit in recognise_figure8s(log, seg, mission)]
        entry["figure8"] = entry["figure8s"][0] if entry["figure8s"] else None  # the first, for short reports
        out.append(entry)
    return {"log": str(log.path), "format": log.fmt, "autopilot": log.autopilot,
            "actual_source": log.actual.label, "target_source": log.target.label if log.target else None,
            "bytes": log.info.get("bytes"), "warnings": list(log.warnings), "segments": out}


def figure8_entry(log: FlightLog, fit: Fit, mission, profile_name: str | None,
                  rms_ref: float | None = None) -> dict[str, Any]:
    T = mission.period
    n_laps = int(math.floor((fit.t_end - fit.t0) / T + 0.02))
    laps = []
    for k in range(max(n_laps, 0)):
        a, b = fit.t0 + k * T, fit.t0 + (k + 1) * T
        laps.append({"lap": k + 1, "t_start_s": a, "vs_target": error_stats(vs_target(log, a, b)[1]),
                     "vs_reference": error_stats(_vs_ref(log, fit, mission, a, b)[1])})
    return {"t0_s": fit.t0, "t_end_s": fit.t_end, "laps_flown": (fit.t_end - fit.t0) / T, "laps": laps,
            "offset_m": [float(x) for x in fit.offset], "fit_rms_m": fit.fit_rms, "marker": fit.marker,
            "mission": {"period_s": T, "north_m": mission.scale, "east_m": mission.scale2,
                        "up_m": mission.center_up, "laps": mission.laps},
            "vs_target": error_stats(vs_target(log, fit.t0, fit.t_end)[1]),
            "vs_reference": error_stats(_vs_ref(log, fit, mission, fit.t0, fit.t_end)[1]),
            "profile": profile_name, "score": mission_score(log, fit, mission, rms_ref)}


def _vs_ref(log: FlightLog, fit: Fit, mission, a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    tr = log.actual.window(a, b)
    sel = tr.t < b
    t = tr.t[sel]
    ref, _ = reference(mission, t - fit.t0, fit.offset)
    return t, tr.pos[sel] - ref


def default_profile(log: FlightLog) -> str:
    return "px4-copter" if log.autopilot == "px4" else "ardupilot-copter"
