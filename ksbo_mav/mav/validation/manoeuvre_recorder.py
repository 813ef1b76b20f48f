"""One validation flight's telemetry and markers -> its figures, live (link taps) or from its tlog: the same code.

Markers (STATUSTEXTs the tool sends, so they are in the tlog in both directions' order; times are the vehicle's
``time_boot_ms``):

* ``ksbo val start <steps|hold|auto> t0=<ms> <gains label>`` — a validation flight starts; anything before is
  forgotten;
* ``ksbo val cfg sf=<settle fraction> sm=<settle floor m> sb=<corner band m> ar=<arrive m>`` — how it is measured;
* ``ksbo val leg t=<ms>`` (steps) — a new position target went out at t: the last one sent; the step is from the
  target before it;
* ``ksbo val hold t=<ms>`` — the autopilot's hold mode was confirmed at t; the hold point is the first position
  sample at or after t;
* ``ksbo val wp <n> <e> <d>`` (one per waypoint, local NED m) and ``ksbo val go t=<ms>`` — the mission's legs and
  the time its mode was confirmed;
* ``ksbo val end t=<ms> <outcome>`` — the measured part ended at t;
* ``ksbo val after t=<ms> <outcome>`` — the flight went wrong after its measured part (e.g. a tilt abort on the
  way back): the flight's outcome is that, as the journal records it, and it has no figures.

The vehicle's own MISSION_ITEM_REACHED reports are kept (stamped with the newest position sample's time): the
mission's ``time_s`` is from its start to the first report of its last item, the autopilot's own "done".
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_task.manoeuvre_metrics import hold_drift, mission_tracking, step_response

MARK = "ksbo val"
CODES = {"steps": "steps", "hold": "hold", "auto_mission": "auto"}
_KIND = {code: kind for kind, code in CODES.items()}
START_RE = re.compile(r"^ksbo val start (steps|hold|auto) t0=(\d+)(?: (.*))?$")
CFG_RE = re.compile(r"^ksbo val cfg sf=(\S+) sm=(\S+) sb=(\S+) ar=(\S+)$")
LEG_RE = re.compile(r"^ksbo val leg t=(\d+)$")
HOLD_RE = re.compile(r"^ksbo val hold t=(\d+)$")
WP_RE = re.compile(r"^ksbo val wp (\S+) (\S+) (\S+)$")
GO_RE = re.compile(r"^ksbo val go t=(\d+)$")
END_RE = re.compile(r"^ksbo val end t=(\d+) (\S+)$")
AFTER_RE = re.compile(r"^ksbo val after t=(\d+) (\S+)$")
MASK_POS = 0x0DF8


def start_text(kind: str, t0_ms: int, label: str) -> str:
    return f"{MARK} start {CODES[kind]} t0={int(t0_ms)} {label}"[:50].rstrip()


def cfg_text(settle_fraction: float, settle_floor_m: float, settle_band_m: float, arrive_m: float) -> str:
    return f"{MARK} cfg sf={settle_fraction:.4g} sm={settle_floor_m:.4g} sb={settle_band_m:.4g} ar={arrive_m:.4g}"


def leg_text(t_ms: int) -> str:
    return f"{MARK} leg t={int(t_ms)}"


def hold_text(t_ms: int) -> str:
    return f"{MARK} hold t={int(t_ms)}"


def wp_text(ned: np.ndarray) -> str:
    return f"{MARK} wp {ned[0]:.3f} {ned[1]:.3f} {ned[2]:.3f}"


def go_text(t_ms: int) -> str:
    return f"{MARK} go t={int(t_ms)}"


def end_text(t_ms: int, outcome: str) -> str:
    return f"{MARK} end t={int(t_ms)} {outcome}"[:50]


def after_text(t_ms: int, outcome: str) -> str:
    return f"{MARK} after t={int(t_ms)} {outcome}"[:50]


@dataclass
class ManoeuvreRecorder:
    """Collects one validation flight. ``vehicle`` = (sysid, compid), or None to take the first vehicle heartbeat
    seen (tlog replay)."""

    vehicle: tuple[int, int] | None = None
    kind: str | None = None
    label: str = ""
    t0: int | None = None
    cfg: tuple[float, float, float, float] = (0.05, 0.1, 0.2, 0.5)
    legs: list[tuple[int, np.ndarray, np.ndarray]] = field(default_factory=list)
    hold_t: int | None = None
    waypoints: list[np.ndarray] = field(default_factory=list)
    go_t: int | None = None
    end_t: int | None = None
    outcome: str = ""
    pos: dict[int, np.ndarray] = field(default_factory=dict)
    att: dict[int, tuple[float, float]] = field(default_factory=dict)
    reached: dict[int, int] = field(default_factory=dict)  # mission seq -> vehicle ms of its first report
    _target: np.ndarray | None = None
    _prev_target: np.ndarray | None = None

    def feed(self, msg: Any, sent: bool) -> None:
        kind = msg.get_type()
        if sent:
            if kind == "STATUSTEXT":
                self._marker(str(msg.text).replace("\0", ""))
            elif kind == "SET_POSITION_TARGET_LOCAL_NED" and msg.coordinate_frame == 1 and msg.type_mask == MASK_POS:
                p = np.array([msg.x, msg.y, msg.z], dtype=float)
                if self._target is None or not np.array_equal(p, self._target):
                    self._prev_target, self._target = self._target, p
            return
        if kind == "HEARTBEAT" and self.vehicle is None and msg.autopilot != 8 and msg.type != 6:
            self.vehicle = (msg.get_srcSystem(), msg.get_srcComponent())
        if self.t0 is None or self.end_t is not None or self.vehicle is None \
                or (msg.get_srcSystem(), msg.get_srcComponent()) != self.vehicle:
            return
        if kind == "LOCAL_POSITION_NED":
            self.pos[int(msg.time_boot_ms)] = np.array([msg.x, msg.y, msg.z], dtype=float)
        elif kind == "MISSION_ITEM_REACHED" and self.go_t is not None and self.pos:
            self.reached.setdefault(int(msg.seq), max(self.pos))
        elif kind == "ATTITUDE":
            self.att[int(msg.time_boot_ms)] = (float(msg.roll), float(msg.pitch))

    def _marker(self, text: str) -> None:
        m = START_RE.match(text)
        if m:
            target, prev, vehicle = self._target, self._prev_target, self.vehicle
            self.__init__(vehicle=vehicle)  # a new flight starts: forget anything before it
            self._target, self._prev_target = target, prev
            self.kind, self.t0, self.label = _KIND[m.group(1)], int(m.group(2)), m.group(3) or ""
            return
        if self.t0 is None:
            return
        if self.end_t is not None:
            if (m := AFTER_RE.match(text)):
                self.outcome = m.group(2)
            return
        if (m := CFG_RE.match(text)):
            self.cfg = tuple(float(g) for g in m.groups())  # type: ignore[assignment]
        elif (m := LEG_RE.match(text)):
            start = self._prev_target if self._prev_target is not None else self._target
            if self._target is not None and start is not None:
                self.legs.append((int(m.group(1)), start.copy(), self._target.copy()))
        elif (m := HOLD_RE.match(text)):
            self.hold_t = int(m.group(1))
        elif (m := WP_RE.match(text)):
            self.waypoints.append(np.array([float(g) for g in m.groups()]))
        elif (m := GO_RE.match(text)):
            self.go_t = int(m.group(1))
        elif (m := END_RE.match(text)):
            self.end_t, self.outcome = int(m.group(1)), m.group(2)

    @property
    def finished(self) -> bool:
        return self.end_t is not None

    def _samples(self, t_from: int, t_to: int) -> tuple[np.ndarray, np.ndarray]:
        ts = np.array(sorted(t for t in self.pos if t_from <= t <= t_to), dtype=float)
        pos = np.array([self.pos[int(t)] for t in ts]).reshape(-1, 3)
        return ts / 1000.0, pos

    def metrics(self) -> dict[str, float]:
        """The flight's figures under fixed names (:mod:`ksbo_task.manoeuvre_metrics`): steps ``step<i>_rise_s``,
        ``step<i>_overshoot_pct``, ``step<i>_settle_s``, ``step<i>_size_m`` and their means ``rise_s_mean``,
        ``overshoot_pct_mean``, ``settle_s_mean``, plus ``steps_unsettled``; hold ``hold_rms_m``, ``hold_max_m``,
        ``hold_vert_rms_m``, ``hold_lean_deg`` (the mean lean that held the vehicle there), ``hold_s``; mission
        ``xtrack_rms_m``, ``xtrack_max_m``, ``vert_rms_m``, ``corner<i>_overshoot_m``, ``corner<i>_settle_s``,
        ``corner_overshoot_m_mean``, ``corner_settle_s_mean``, ``corners_unsettled``, ``final_overshoot_m``,
        ``final_settle_s``, ``time_s`` (to the vehicle's report of its last item; without reports, to ``arrive_s``)
        and ``arrive_s`` (to the first sample within the arrival radius of the last waypoint). NaN where a figure
        does not exist (a step that never settled)."""
        if self.t0 is None:
            raise InputError("no validation start marker ('ksbo val start ...') in the log")
        if self.end_t is None:
            raise InputError("the validation flight has no end marker ('ksbo val end ...'): the log stops mid-flight")
        sf, sm, sb, ar = self.cfg
        if self.kind == "steps":
            return self._steps(sf, sm)
        if self.kind == "hold":
            return self._hold()
        if self.go_t is None or len(self.waypoints) < 2:
            return {}
        t, pos = self._samples(self.go_t, self.end_t)
        out = mission_tracking(t, pos, np.array(self.waypoints), settle_band_m=sb, arrive_m=ar)
        out["arrive_s"] = out.pop("time_s")
        done = self.reached.get(max(self.reached)) if self.reached else None
        out["time_s"] = (done - self.go_t) / 1000.0 if done is not None else out["arrive_s"]
        return out

    def _steps(self, sf: float, sm: float) -> dict[str, float]:
        out: dict[str, float] = {}
        bounds = [leg[0] for leg in self.legs[1:]] + [self.end_t]
        rows = []
        for i, ((t_ms, start, target), t_next) in enumerate(zip(self.legs, bounds), 1):
            t, pos = self._samples(t_ms, int(t_next))
            r = step_response(t, pos, start, target, t_ms / 1000.0, settle_fraction=sf, settle_floor_m=sm)
            rows.append(r)
            out.update({f"step{i}_{k}": v for k, v in r.items()})
        for k in ("rise_s", "overshoot_pct", "settle_s"):
            vals = [r[k] for r in rows if math.isfinite(r[k])]
            out[f"{k}_mean"] = float(np.mean(vals)) if vals else math.nan
        out["steps_unsettled"] = float(sum(1 for r in rows if not math.isfinite(r["settle_s"])))
        return out

    def _hold(self) -> dict[str, float]:
        if self.hold_t is None:
            return {}
        t, pos = self._samples(self.hold_t, int(self.end_t))
        if not len(t):
            return {}
        d = hold_drift(pos, pos[0])
        att = np.array([self.att[k] for k in sorted(self.att) if self.hold_t <= k <= self.end_t]).reshape(-1, 2)
        lean = math.degrees(math.hypot(*att.mean(axis=0))) if len(att) else math.nan
        return {"hold_rms_m": d["rms_m"], "hold_max_m": d["max_m"], "hold_vert_rms_m": d["vert_rms_m"],
                "hold_lean_deg": lean, "hold_s": float(t[-1] - t[0])}


def recorders_from_tlog(records: list[Any]) -> list[ManoeuvreRecorder]:
    """Every finished validation flight in tlog records (:func:`ksbo_mav.mav.tlog.read_tlog`), in order."""
    out: list[ManoeuvreRecorder] = []
    rec = ManoeuvreRecorder()
    for r in records:
        if out and r.sent and r.msg.get_type() == "STATUSTEXT" and AFTER_RE.match(str(r.msg.text).replace("\0", "")):
            out[-1].feed(r.msg, r.sent)  # what happened after the last flight's measured part
        rec.feed(r.msg, r.sent)
        if rec.finished:
            out.append(rec)
            rec = ManoeuvreRecorder(vehicle=rec.vehicle)
            rec._target, rec._prev_target = out[-1]._target, out[-1]._prev_target
    return out
