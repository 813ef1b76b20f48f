"""Which stretches of a log count: armed, airborne, in a target-tracking mode, with position targets, and enough
motion to judge. Everything else that was in a tracking mode is listed as skipped, with the reason.

* armed: the log's arming record (HEARTBEAT armed flag, DataFlash ARM/EV, ULog vehicle_status.arming_state) —
  a mode chosen on the ground before arming does not start a segment;
* airborne: the landed state when the log has it (tlog EXTENDED_SYS_STATE), else more than ``MIN_HEIGHT`` above
  the take-off point (the position when the vehicle armed); a log that starts already armed has no take-off
  point and counts as airborne;
* split where a tuned parameter (``PSC_*``, ``MPC_*``) changed in flight (``PARM`` / ``PARAM_VALUE``).
"""

from __future__ import annotations

import math

import numpy as np

from ksbo_mav.flightlog.model import FlightLog, Segment

MIN_HEIGHT = 0.3  # m above the take-off point
MIN_MOTION = 0.5  # m: a target that moved less is not a tracking test
TUNED = ("PSC_", "MPC_")


def _spans(log: FlightLog) -> list[tuple[float, float, str, bool]]:
    if not log.modes:
        return [(float(log.target.t[0]), float(log.target.t[-1]), "unknown mode", True)]
    out = []
    for i, m in enumerate(log.modes):
        if m.tracking:
            end = log.modes[i + 1].t if i + 1 < len(log.modes) else math.inf
            out.append((m.t, end, m.name, i + 1 == len(log.modes)))
    return out


def takeoff_d(log: FlightLog, t: float) -> float | None:
    """Down coordinate of the take-off point for a span starting at ``t``: the position at the last arming before
    it (None when the log does not show the vehicle arming)."""
    t_arm = None
    for prev, m in zip(log.modes, log.modes[1:]):
        if m.t > t:
            break
        if prev.name == "DISARMED" and m.name != "DISARMED":
            t_arm = m.t
    if t_arm is None:
        return None
    before = log.actual.window(t_arm - 5.0, t_arm - 1e-6)
    if len(before):
        return float(before.pos[-1, 2])
    after = log.actual.window(t_arm, t_arm + 1.0)
    return float(after.pos[0, 2]) if len(after) else None


def _airborne(log: FlightLog, a: float, b: float) -> tuple[float, float] | str:
    """The airborne part ``(a', b')`` of [a, b], or why there is none."""
    landed = log.info.get("landed") or []
    tr = log.actual.window(a, b)
    if len(tr) == 0:
        return "no position samples"
    if landed:
        ts = np.array([x[0] for x in landed])
        st = np.array([x[1] for x in landed])
        i = np.searchsorted(ts, tr.t, side="right") - 1
        air = np.where(i >= 0, np.isin(st[np.clip(i, 0, None)], (2, 3, 4)), True)
        why = "landed state 'on ground' throughout (EXTENDED_SYS_STATE)"
    else:
        d0 = takeoff_d(log, a)
        if d0 is None:
            return a, b
        height = d0 - tr.pos[:, 2]
        air = height > MIN_HEIGHT
        why = (f"on the ground: never more than {MIN_HEIGHT} m above the take-off point "
               f"(highest {max(float(height.max()), 0.0):.2f} m)")
    if not air.any():
        return why
    idx = np.flatnonzero(air)
    return float(tr.t[idx[0]]), float(tr.t[idx[-1]])


def _param_splits(log: FlightLog, a: float, b: float) -> list[tuple[float, str]]:
    seen: dict[str, float] = {}
    out = []
    for t, name, value in sorted(log.info.get("param_changes") or [], key=lambda x: x[0]):
        if not name.startswith(TUNED):
            continue
        if name in seen and seen[name] != value and a < t < b:
            out.append((t, f"{name} {seen[name]:g} -> {value:g}"))
        seen[name] = value
    return out


def find_segments(log: FlightLog, min_duration: float = 2.0) -> tuple[list[Segment], list[dict]]:
    """(segments to score, skipped stretches ``{t_start_s, t_end_s, mode, reason}``)."""
    if log.target is None or len(log.target) == 0:
        return [], []
    t_lo, t_hi = float(log.actual.t[0]), float(log.actual.t[-1])
    out: list[Segment] = []
    skipped: list[dict] = []

    def skip(a, b, name, reason):
        skipped.append({"t_start_s": a, "t_end_s": b, "mode": name, "reason": reason})

    for a, b, name, last in _spans(log):
        a, b = max(a, t_lo), min(b, t_hi)
        if b - a < min_duration:
            if b > a:
                skip(a, b, name, f"shorter than {min_duration:g} s")
            continue
        air = _airborne(log, a, b)
        if isinstance(air, str):
            skip(a, b, name, air)
            continue
        splits = _param_splits(log, *air)
        cuts = [air[0]] + [t for t, _ in splits] + [air[1]]
        whys = [""] + [w for _, w in splits]
        for k in range(len(cuts) - 1):
            s0, s1 = cuts[k], cuts[k + 1]
            tg = log.target.window(s0, s1)
            if s1 - s0 < min_duration or len(tg) < 10:
                skip(s0, s1, name, f"fewer than 10 target samples or shorter than {min_duration:g} s")
                continue
            span = float(np.max(np.ptp(tg.pos, axis=0)))
            if span < MIN_MOTION:
                skip(s0, s1, name, f"too little motion to judge: the target moved {span:.2f} m "
                                   f"(at least {MIN_MOTION} m needed)")
                continue
            out.append(Segment(len(out) + 1, s0, s1, name, last and k == len(cuts) - 2, whys[k]))
    return out, skipped
