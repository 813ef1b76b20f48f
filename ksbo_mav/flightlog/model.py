"""What every flight-log reader produces: time series in the vehicle's local NED frame, on the vehicle clock.

Times are seconds since the autopilot booted (DataFlash ``TimeUS``, ULog ``timestamp``, MAVLink
``time_boot_ms``): one clock for the position, the autopilot's target, mode changes and trial markers, so a
``.BIN``/``.ulg`` and a tlog of the same flight line up without any alignment.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np


@dataclass
class Track:
    """Samples of a NED position (m), optionally velocity (m/s), at times ``t`` (s, vehicle clock, increasing)."""

    t: np.ndarray
    pos: np.ndarray  # (n, 3)
    vel: np.ndarray | None = None  # (n, 3)
    label: str = ""

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, dtype=float)
        self.pos = np.asarray(self.pos, dtype=float).reshape(-1, 3)
        if self.vel is not None:
            self.vel = np.asarray(self.vel, dtype=float).reshape(-1, 3)
        if self.t.size > 1 and np.any(np.diff(self.t) < 0):  # a log's messages are stamped in order; be safe
            order = np.argsort(self.t, kind="stable")
            self.t, self.pos = self.t[order], self.pos[order]
            self.vel = self.vel[order] if self.vel is not None else None
        ok = np.all(np.isfinite(self.pos), axis=1)  # PX4 logs NaN for axes it does not control
        if not ok.all():
            self.t, self.pos = self.t[ok], self.pos[ok]
            self.vel = self.vel[ok] if self.vel is not None else None

    def __len__(self) -> int:
        return int(self.t.size)

    def window(self, t0: float, t1: float) -> "Track":
        sel = (self.t >= t0) & (self.t <= t1)
        return Track(self.t[sel], self.pos[sel], None if self.vel is None else self.vel[sel], self.label)

    def at(self, t: np.ndarray, max_gap: float = 0.5) -> np.ndarray:
        """(len(t), 3) positions linearly interpolated at ``t``; NaN where the nearest samples on either side are
        more than ``max_gap`` s apart or ``t`` is outside the track."""
        return _interp(self.t, self.pos, np.asarray(t, dtype=float), max_gap)

    def vel_at(self, t: np.ndarray, max_gap: float = 0.5) -> np.ndarray:
        if self.vel is None:
            return np.full((np.size(t), 3), np.nan)
        return _interp(self.t, self.vel, np.asarray(t, dtype=float), max_gap)


def _interp(ts: np.ndarray, ys: np.ndarray, t: np.ndarray, max_gap: float) -> np.ndarray:
    out = np.full((t.size, ys.shape[1]), np.nan)
    if ts.size < 2 or t.size == 0:
        return out
    i = np.searchsorted(ts, t)
    ok = (i > 0) & (i < ts.size)
    exact = np.isin(t, ts)
    lo, hi = np.clip(i - 1, 0, ts.size - 1), np.clip(i, 0, ts.size - 1)
    ok &= (ts[hi] - ts[lo]) <= max_gap
    for k in range(ys.shape[1]):
        out[:, k] = np.interp(t, ts, ys[:, k])
    out[~(ok | exact)] = np.nan
    return out


@dataclass
class Outputs:
    """The autopilot's servo/motor outputs (µs) at times ``t`` (s, vehicle clock): ``pwm`` (n, k), a column a
    channel, as logged (ArduPilot ``RCOU`` C1..). :func:`ksbo_mav.smoothness.motor_oscillation` reads them."""

    t: np.ndarray
    pwm: np.ndarray
    label: str = ""

    def window(self, t0: float, t1: float) -> tuple[np.ndarray, np.ndarray]:
        """(times, outputs) with ``t0 <= t < t1``."""
        sel = (self.t >= t0) & (self.t < t1)
        return self.t[sel], self.pwm[sel]


@dataclass
class ModeChange:
    t: float
    name: str
    tracking: bool  # a mode in which the vehicle follows position targets (guided / auto / offboard)


@dataclass
class Marker:
    """A ksbo trial marker found in the log (STATUSTEXT in a tlog, MSG in a .BIN, logged message in a .ulg)."""

    t: float
    text: str


@dataclass
class FlightLog:
    """One flight log, format-independent. ``target`` is the autopilot's own logged position target (the
    position controller's); ``commanded`` the setpoints a ground station streamed, when the log has them."""

    path: Path
    fmt: str  # "tlog" | "bin" | "ulg"
    autopilot: str  # "ardupilot" | "px4" | "unknown"
    actual: Track
    target: Track | None
    commanded: Track | None
    modes: list[ModeChange]
    markers: list[Marker] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    info: dict[str, Any] = field(default_factory=dict)
    outputs: Outputs | None = None  # the motor outputs where the log has them (ArduPilot RCOU)
    truncated_at: float | None = None  # vehicle time of the last complete sample before a cut, if the file is cut
    skipped: list = field(default_factory=list)  # damaged spans the reader skipped (Skipped)


@dataclass
class Segment:
    index: int  # 1-based
    t_start: float
    t_end: float
    mode: str
    open_end: bool  # the log ends while still in this segment
    note: str = ""  # why it starts here when not at a mode change (a tuned parameter changed)


@dataclass
class Skipped:
    offset: int  # first byte skipped
    nbytes: int
    t_before: float | None = None  # vehicle time (s) of the last sample before the damage
    t_after: float | None = None  # ... and of the first after it
    why: str = ""  # what was wrong where the damage starts, when the reader can tell

    def describe(self) -> str:
        when = ""
        if self.t_before is not None or self.t_after is not None:
            a = "start" if self.t_before is None else f"{self.t_before:.1f}"
            b = "end" if self.t_after is None else f"{self.t_after:.1f}"
            when = f", t={a}..{b} s"
        why = f" ({self.why})" if self.why else ""
        return f"{self.nbytes} damaged bytes skipped at offset {self.offset}{when}{why}"
