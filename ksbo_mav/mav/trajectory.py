"""One trial's telemetry and logged setpoints -> :class:`ksbo_task.flight.Trajectory`.

:class:`TrialRecorder` is fed every packet of a link in both directions, *as decoded from the wire*: live by the
link's taps, offline from a tlog. Both paths therefore see the same numbers (float32 setpoints included) and the
score recomputed from a tlog equals the live score exactly.

A trial is delimited by two STATUSTEXTs the client sends (a ground station may send STATUSTEXT; vehicles
forward or ignore it, and other ground stations on the link see what the tuner is doing):

* ``ksbo f8 start t0=<ms> n=<steps> dt=<ms> w=<first scored step>`` (``f8h`` for the horizontal figure-8) —
  the reference step j belongs to vehicle time ``t0 + j*dt`` (``time_boot_ms``); steps w..n-1 are scored;
* ``ksbo f8 end L=<steps flown> <outcome>``.

A figure-8 flown on board (:mod:`ksbo_mav.mav.onboard_trial`) sends no setpoints: after the start marker, ``ksbo f8h
board a=<north m> b=<east m> p=<period s> up=<m> li=<lead-in s>`` names the pattern whose reference at each sample's
stamp (:class:`ksbo_task.figure8_ne.Figure8H`, t = 0 at ``t0``) stands in for the logged setpoints.

Pairing (fact sheet / scoring module): the state after control step k is the telemetry sample stamped
``t0 + (k+1)*dt`` (the nearest step for a jittery stream), compared with the logged setpoint the client sent in
answer to that sample, stamped with the sample's time (the reference at that instant). Samples lost
on the link are filled by linear interpolation across gaps of at most :data:`MAX_GAP` steps (at the trial's first
or last step, by holding the nearest sample); longer gaps stay missing and make the scored window incomplete.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.mav.mission import KINDS, MASK_POS_VEL_ACC, task_ref, task_state
from ksbo_task.figure8_ne import Figure8H
from ksbo_task.flight import Trajectory

MAX_GAP = 5
START_RE = re.compile(r"^ksbo (f8h?) start t0=(\d+) n=(\d+) dt=(\d+) w=(\d+)$")
REF_RE = re.compile(r"^ksbo f8h? ref rms=([0-9.eE+-]+)(?: rough=([0-9.eE+-]+))?$")
END_RE = re.compile(r"^ksbo f8h? end L=(\d+) (\S+)$")
AFTER_RE = re.compile(r"^ksbo f8h? after (\S+)$")
_NUM = r"([0-9.eE+-]+)"
BOARD_RE = re.compile(rf"^ksbo f8h board a={_NUM} b={_NUM} p={_NUM} up={_NUM} li={_NUM}$")
_TAG_KIND = {tag: kind for kind, tag in KINDS.items()}


def start_text(tag: str, t0_ms: int, n: int, dt_ms: int, w: int) -> str:
    return f"ksbo {tag} start t0={t0_ms} n={n} dt={dt_ms} w={w}"


def ref_text(tag: str, rms_ref: float, rough_ref: float | None = None) -> str:
    """Marker sent after the start marker: the campaign's reference RMS (its baseline flight's lap-2 RMS) and
    roughness (deg/s, :mod:`ksbo_mav.smoothness`), so the score recomputed from the tlog is the live score."""
    rough = "" if rough_ref is None else f" rough={rough_ref:.6g}"
    return f"ksbo {tag} ref rms={rms_ref:.6g}{rough}"


def board_text(f: Figure8H) -> str:
    """Marker sent after the start marker of a figure-8 flown on board: the pattern, to the float32 precision the
    script was rendered from (the markers carry 50 characters)."""
    return f"ksbo f8h board a={f.amp_north:.6g} b={f.amp_east:.6g} p={f.period:.6g} up={f.altitude:.6g} " \
        f"li={f.lead_in:.6g}"


def end_text(tag: str, L: int, outcome: str) -> str:
    return f"ksbo {tag} end L={L} {outcome}"[:50]


def after_text(tag: str, outcome: str) -> str:
    """Marker sent after the end marker when a trial that ended "ok" turns out otherwise (the vehicle crashed as
    the baseline took over): the trial's outcome becomes ``outcome``."""
    return f"ksbo {tag} after {outcome}"[:50]


@dataclass
class TrialRecorder:
    """Collects one trial. ``vehicle`` = (sysid, compid) of the vehicle, or None to take the first vehicle
    heartbeat seen (tlog replay)."""

    vehicle: tuple[int, int] | None = None
    kind: str = "figure8-xz"
    t0: int | None = None
    n: int = 0
    dt: int = 0
    w: int = 0
    L: int | None = None
    outcome: str = ""
    pos: dict[int, np.ndarray] = field(default_factory=dict)
    att: dict[int, np.ndarray] = field(default_factory=dict)
    act: dict[int, np.ndarray] = field(default_factory=dict)
    motors: dict[float, np.ndarray] = field(default_factory=dict)  # SERVO_OUTPUT_RAW by vehicle time (ms)
    refs: dict[int, np.ndarray] = field(default_factory=dict)
    rms_ref: float | None = None
    rough_ref: float | None = None
    board: Figure8H | None = None  # the figure-8 flown on board: the reference instead of logged setpoints
    lost: int = 0  # vehicle packets lost on the link during the trial (MAVLink sequence gaps)
    _seq: dict[int, int] = field(default_factory=dict)
    _boot_ms: int | None = None  # the vehicle's latest time_boot_ms: SERVO_OUTPUT_RAW's 32-bit µs stamp is read near it

    def feed(self, msg: Any, sent: bool) -> None:
        kind = msg.get_type()
        if sent:
            if kind == "STATUSTEXT":
                self._marker(str(msg.text))
            elif kind == "SET_POSITION_TARGET_LOCAL_NED" and self.t0 is not None and self.L is None \
                    and msg.type_mask == MASK_POS_VEL_ACC and msg.coordinate_frame == 1:
                self.refs[int(msg.time_boot_ms)] = _ned(msg)
            return
        if kind == "HEARTBEAT" and self.vehicle is None and msg.autopilot != 8 and msg.type != 6:
            self.vehicle = (msg.get_srcSystem(), msg.get_srcComponent())
        if self.t0 is None or self.L is not None or self.vehicle is None \
                or (msg.get_srcSystem(), msg.get_srcComponent()) != self.vehicle:
            return
        comp, seq = msg.get_srcComponent(), msg.get_seq()
        if comp in self._seq:
            gap = (seq - self._seq[comp] - 1) % 256
            self.lost += gap if gap < 128 else 0  # a large "gap" is a reordered / duplicated packet, not a loss
        self._seq[comp] = seq
        if kind in ("LOCAL_POSITION_NED", "ATTITUDE"):
            self._boot_ms = int(msg.time_boot_ms)
        if kind == "LOCAL_POSITION_NED":
            self.pos[int(msg.time_boot_ms)] = _ned(msg)
        elif kind == "SERVO_OUTPUT_RAW" and self._boot_ms is not None:
            self.motors[_near_ms(int(msg.time_usec), self._boot_ms)] = np.array(
                [getattr(msg, f"servo{i}_raw") for i in range(1, 9)], dtype=float)
        elif kind == "ATTITUDE":
            self.att[int(msg.time_boot_ms)] = np.array([msg.roll, msg.pitch, msg.rollspeed, msg.pitchspeed],
                                                       dtype=float)
        elif kind == "ACTUATOR_OUTPUT_STATUS":
            self.act[int(msg.time_usec // 1000)] = np.array(msg.actuator[:2], dtype=float)

    def _marker(self, text: str) -> None:
        m = START_RE.match(text)
        if m:
            t0, n, dt, w = (int(g) for g in m.groups()[1:])
            self.__init__(vehicle=self.vehicle)  # a new trial starts: forget anything before it
            self.kind = _TAG_KIND[m.group(1)]
            self.t0, self.n, self.dt, self.w = t0, n, dt, w
            return
        m = REF_RE.match(text)
        if m and self.t0 is not None and self.L is None:
            self.rms_ref = float(m.group(1))
            self.rough_ref = None if m.group(2) is None else float(m.group(2))
            return
        m = BOARD_RE.match(text)
        if m and self.t0 is not None and self.L is None:
            a, b, p, up, li = (float(g) for g in m.groups())
            self.board = Figure8H(amp_north=a, amp_east=b, period=p, altitude=up, lead_in=li)
            return
        m = END_RE.match(text)
        if m and self.t0 is not None and self.L is None:
            self.L, self.outcome = int(m.group(1)), m.group(2)
            return
        m = AFTER_RE.match(text)
        if m and self.L is not None and self.outcome == "ok":
            self.outcome = m.group(1)

    @property
    def finished(self) -> bool:
        return self.L is not None

    def trajectory(self, source: str) -> tuple[Trajectory, dict[str, Any]]:
        """The trial as a :class:`Trajectory` plus bookkeeping (samples filled / missing, outcome)."""
        if self.t0 is None:
            raise InputError("no trial start marker ('ksbo f8 start ...') in the log")
        if self.L is None:
            raise InputError("the trial has no end marker ('ksbo f8 end ...'): the log stops mid-trial")
        L = min(self.L, self.n)
        if self.kind == "figure8-ne":
            return self._by_sample(L, source)
        col = lambda d, w: _column(d, self.t0, self.dt, L, w)  # noqa: E731
        planar = self.kind == "figure8-xz"
        cols = {"pos": col(self.pos, 6), "ref": col(self.refs, 6)}
        if planar:  # pitch is a task state, thrusts enter P(a)'s input term
            cols["att"] = col(self.att, 4)
        have_act = planar and bool(self.act)
        if have_act:
            cols["act"] = col(self.act, 2)
        missing = {k: int(np.isnan(c[:, 0]).sum()) for k, c in cols.items()}
        filled = {k: _fill(c) for k, c in cols.items()}
        still = {k: int(np.isnan(c[:, 0]).sum()) for k, c in cols.items()}
        att = cols.get("att", np.full((L, 4), np.nan))
        states = np.array([task_state(self.kind, p, a) for p, a in zip(cols["pos"], att)]).reshape(L, 6)
        refs = np.array([task_ref(self.kind, r) for r in cols["ref"]]).reshape(L, 6)
        traj = Trajectory(t=(np.arange(L) + 1) * self.dt / 1000.0, steps=np.arange(L), states=states,
                          refs=refs, inputs=cols["act"] if have_act else None, L=L, source=source)
        info = {"kind": self.kind, "t0_ms": self.t0, "n": self.n, "dt_ms": self.dt, "window": [self.w, self.n],
                "L": L, "outcome": self.outcome,
                "missing": missing, "filled": filled, "unfilled": still, "inputs": have_act}
        return traj, info


    def _by_sample(self, L: int, source: str) -> tuple[Trajectory, dict[str, Any]]:
        """3-D missions: every received sample, paired with the logged setpoints interpolated to its own stamp
        (setpoints go out every step, so linear interpolation is within a_max dt^2 / 8 = 5e-5 m of the
        reference). Works at any telemetry rate; :meth:`Mission.score` decides whether the rate suffices."""
        t0, dt = int(self.t0), self.dt
        T = np.array(sorted(t for t in self.pos if t0 < t <= t0 + L * dt), dtype=float)
        rt = np.array(sorted(self.refs), dtype=float)
        pos = np.array([self.pos[int(t)] for t in T]).reshape(-1, 6)
        ref = np.full((len(T), 6), np.nan)
        if self.board is not None and len(T):  # flown on board: the pattern's reference at each stamp
            p, v, _ = self.board.state((T - t0) / 1000.0)
            ref = np.concatenate([p, v], axis=1)
        elif len(rt) >= 2 and len(T):
            rv = np.array([self.refs[int(t)] for t in rt])
            inside = (T >= rt[0]) & (T <= rt[-1])
            for c in range(6):
                ref[inside, c] = np.interp(T[inside], rt, rv[:, c])
        nan_att = np.full(4, np.nan)
        states = np.array([task_state(self.kind, p, nan_att) for p in pos]).reshape(-1, 6)
        refs = np.array([task_ref(self.kind, r) for r in ref]).reshape(-1, 6)
        steps = np.rint((T - t0) / dt).astype(int) - 1
        traj = Trajectory(t=(T - t0) / 1000.0, steps=steps, states=states, refs=refs, inputs=None, L=L,
                          source=source)
        info = {"kind": self.kind, "t0_ms": t0, "n": self.n, "dt_ms": dt, "window": [self.w, self.n], "L": L,
                "outcome": self.outcome, "samples": int(len(T)), "setpoints": int(len(rt)),
                "lost_packets": int(self.lost), "rms_ref": self.rms_ref,
                "rough_ref": self.rough_ref, "on_board": self.board is not None}
        return traj, info


def _near_ms(usec32: int, boot_ms: int) -> float:
    """A 32-bit microsecond stamp (ArduPilot's wraps every 71.6 min; PX4's and ours are truncated to 32 bits on
    the wire) as vehicle milliseconds: the value of that residue nearest ``boot_ms``."""
    span = 1 << 32
    off = (usec32 - boot_ms * 1000) % span
    return boot_ms + (off - span if off >= span // 2 else off) / 1000.0


def _ned(msg: Any) -> np.ndarray:
    """[x, y, z, vx, vy, vz] of a LOCAL_POSITION_NED or SET_POSITION_TARGET_LOCAL_NED."""
    return np.array([msg.x, msg.y, msg.z, msg.vx, msg.vy, msg.vz], dtype=float)


def _column(d: dict[int, np.ndarray], t0: int, dt: int, L: int, width: int) -> np.ndarray:
    """Samples by control step: a stamp T belongs to the state after step k = round((T - t0) / dt) - 1 (exact in
    lockstep; the nearest step for a real vehicle's jittery stream). Of two stamps in one step the later wins."""
    out = np.full((L, width), np.nan)
    for t in sorted(d):
        k = int(round((t - t0) / dt)) - 1
        if 0 <= k < L:
            out[k] = d[t]
    return out


def _fill(col: np.ndarray) -> int:
    """Fill NaN runs of length <= MAX_GAP (in place): linear interpolation inside the trial, the nearest sample
    held at its first or last step (a packet lost there has only one neighbour); returns samples filled."""
    bad = np.isnan(col[:, 0])
    if not bad.any():
        return 0
    idx = np.flatnonzero(~bad)
    filled = 0
    i, n = 0, len(col)
    while i < n:
        if not bad[i]:
            i += 1
            continue
        j = i
        while j < n and bad[j]:
            j += 1
        if j - i <= MAX_GAP and idx.size:
            if i > 0 and j < n:
                w = (np.arange(i, j) - (i - 1)) / (j - (i - 1))
                col[i:j] = col[i - 1] + w[:, None] * (col[j] - col[i - 1])
            else:
                col[i:j] = col[j] if i == 0 else col[i - 1]
            filled += j - i
        i = j
    return filled


def trajectory_from_tlog(records: list[Any]) -> tuple[Trajectory, dict[str, Any], TrialRecorder]:
    """Replay tlog records (see :func:`ksbo_mav.mav.tlog.read_tlog`) through a recorder."""
    rec = TrialRecorder()
    for r in records:
        rec.feed(r.msg, r.sent)
    traj, info = rec.trajectory("tlog")
    return traj, info, rec
