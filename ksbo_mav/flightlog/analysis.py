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
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.flightlog.figure8_fit import Fit, _ref_marker, recognise_figure8, recognise_figure8s, reference  # noqa: F401
from ksbo_mav.flightlog.model import FlightLog, Segment
from ksbo_mav.flightlog.segments import find_segments as _find
from ksbo_mav.flightlog.spectrum import error_spectrum, summary
from ksbo_mav.smoothness import motor_oscillation



def find_segments(log: FlightLog, min_duration: float = 2.0) -> list[Segment]:
    """The segments that count (see :mod:`ksbo_mav.flightlog.segments`)."""
    return _find(log, min_duration)[0]


def damage_in(log: FlightLog, seg: Segment) -> list[str]:
    """Damaged spans the reader skipped that fall inside (or cannot be placed outside) a segment."""
    out = []
    for sk in log.skipped:
        a = -math.inf if sk.t_before is None else sk.t_before
        b = math.inf if sk.t_after is None else sk.t_after
        if a > b:  # a timestamp the damage itself overwrote (the record cut by it): the span cannot be placed
            a, b = -math.inf, math.inf
        if a <= seg.t_end and b >= seg.t_start:
            out.append(sk.describe())
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


def mission_score(log: FlightLog, fit: Fit, mission, rms_ref: float | None = None) -> dict[str, Any]:
    """The profile's score (``Mission.score``) of the figure-8, or the reason there is none. ``rms_ref`` (the
    campaign's baseline lap-2 RMS; default: the trial's ``ref rms=`` marker when logged) makes P comparable with
    the live score; without one a flight is its own reference."""
    from ksbo_task.flight import Trajectory

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
    segs, skipped = _find(log)
    if log.skipped:
        log.warnings.append(f"skipped {len(log.skipped)} damaged span(s): "
                            + "; ".join(sk.describe() for sk in log.skipped[:5])
                            + (f" (+{len(log.skipped) - 5} more)" if len(log.skipped) > 5 else ""))
    if not segs:
        raise InputError(f"{log.path}: " + no_segment_reason(log, skipped))
    if log.truncated_at is None and log.fmt in ("bin", "ulg") and segs[-1].open_end:
        # An onboard log closes after disarm; one that stops in a tracking mode was cut on a message boundary.
        log.truncated_at = float(log.actual.t[-1])
        log.info["truncated"] = (f"it stops at t={log.truncated_at:.1f} s in {segs[-1].mode}, before any mode "
                                 f"change or disarm")
    incomplete = {}
    for seg in segs:
        why = damage_in(log, seg)
        if seg.open_end and log.truncated_at is not None:
            why.append(f"the log is truncated ({log.info.get('truncated', '')})")
        if why:
            incomplete[seg.index] = "; ".join(why)
    if log.truncated_at is not None and not any(s.open_end for s in segs):
        log.warnings.append(f"{log.path} is truncated ({log.info.get('truncated', '')}); every segment ended "
                            f"before the cut")
    if only is not None:
        if not 1 <= only <= len(segs):
            raise InputError(f"{log.path}: --segment {only} does not exist (segments 1..{len(segs)})")
        segs = [segs[only - 1]]
    if incomplete and not partial:
        keep = [s for s in segs if s.index not in incomplete]
        for s in segs:
            if s.index in incomplete:
                skipped.append({"t_start_s": s.t_start, "t_end_s": s.t_end, "mode": s.mode,
                                "reason": f"segment {s.index} is incomplete: {incomplete[s.index]}; --partial "
                                          f"scores what is there"})
        if not keep:
            s = next(s for s in segs if s.index in incomplete)
            raise InputError(f"{log.path}: segment {s.index} ({s.mode} from t={s.t_start:.1f} s) is incomplete: "
                             f"{incomplete[s.index]}; pass --partial to score what is there")
        segs = keep
    for idx, why in incomplete.items():
        if partial and any(s.index == idx for s in segs):
            log.warnings.append(f"segment {idx} is incomplete ({why}): scored from what is there")
    out = []
    for seg in segs:
        t, e = vs_target(log, seg.t_start, seg.t_end + 1e-9)
        entry: dict[str, Any] = {"segment": seg.index, "mode": seg.mode, "t_start_s": seg.t_start, "note": seg.note,
                                 "t_end_s": seg.t_end, "duration_s": seg.t_end - seg.t_start,
                                 "vs_target": error_stats(e), "figure8": None,
                                 "spectrum": summary(error_spectrum(log, seg.t_start, seg.t_end))}
        entry["figure8s"] = [figure8_entry(log, fit, fit.mission, profile_name, rms_ref)
                             for fit in recognise_figure8s(log, seg, mission)]
        entry["figure8"] = entry["figure8s"][0] if entry["figure8s"] else None  # the first, for short reports
        out.append(entry)
    return {"log": str(log.path), "format": log.fmt, "autopilot": log.autopilot,
            "actual_source": log.actual.label, "target_source": log.target.label if log.target else None,
            "bytes": log.info.get("bytes"), "version": log.info.get("version"),
            "skipped_segments": skipped, "damaged_spans": [vars(sk) for sk in log.skipped],
            "warnings": list(log.warnings), "segments": out}


def no_segment_reason(log: FlightLog, skipped: list[dict]) -> str:
    """One line: why nothing in the log can be scored."""
    if log.target is None:
        return log.info.get("no_targets") or "no position targets in the log"
    if skipped:
        parts = [f"{s['mode']} t={s['t_start_s']:.1f}..{s['t_end_s']:.1f} s: {s['reason']}" for s in skipped[:3]]
        more = f" (+{len(skipped) - 3} more)" if len(skipped) > 3 else ""
        return "no segment to score; skipped " + "; ".join(parts) + more
    seen = ", ".join(dict.fromkeys(m.name for m in log.modes)) or "none logged"
    return (f"no segment where the vehicle tracked position targets in a guided/auto/offboard mode "
            f"(modes seen: {seen})")


def figure8_entry(log: FlightLog, fit: Fit, mission, profile_name: str | None,
                  rms_ref: float | None = None) -> dict[str, Any]:
    T = mission.period
    n_laps = int(math.floor((fit.t_end - fit.t0) / T + 0.02))
    laps = []
    for k in range(max(n_laps, 0)):
        a, b = fit.t0 + k * T, fit.t0 + (k + 1) * T
        lap = {"lap": k + 1, "t_start_s": a, "vs_target": error_stats(vs_target(log, a, b)[1]),
               "vs_reference": error_stats(_vs_ref(log, fit, mission, a, b)[1])}
        if log.outputs is not None:  # what the motors did in the lap (ksbo_mav.smoothness)
            m = motor_oscillation(*log.outputs.window(a, b))
            lap["motor_osc_us"] = m["motor_osc_us"]
            if m.get("motor_note"):
                lap["motor_note"] = m["motor_note"]
        laps.append(lap)
    return {"t0_s": fit.t0, "t_end_s": fit.t_end, "laps_flown": (fit.t_end - fit.t0) / T, "laps": laps,
            "offset_m": [float(x) for x in fit.offset], "fit_rms_m": fit.fit_rms, "marker": fit.marker,
            "mission": {"period_s": T, "north_m": mission.scale, "east_m": mission.scale2,
                        "up_m": mission.center_up, "laps": mission.laps, "lead_in_s": mission.lead_in},
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
