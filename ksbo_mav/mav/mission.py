"""The figure-8 missions in the vehicle's local NED frame, how their setpoints look on the wire, and their scores.

* ``figure8-xz`` (planar task, ``sim-planar``): Safe Control Gym's figure-8, planar x <-> NED north, planar z (up)
  <-> -NED down, east 0. Task states [x, vx, z, vz, theta, theta_dot] (NED pitch = -theta); scored with the
  paper's P(a) (:mod:`ksbo_mav.scoring`), lap 2.
* ``figure8-ne`` (3-D copters, fact sheet 8): north = A sin(wt), east = B sin(2wt) at a constant height. Task
  states [north, v_north, east, v_east, up, v_up]; scored by the lap-2 RMS tracking error e (m) relative to the
  campaign's baseline flight: ``P = 1 - e / (ratio * e_baseline)`` (:meth:`Mission.score`), so the baseline
  scores 0.5 on any vehicle and P < 0 means more than ``ratio`` (2) times worse; an early end scores
  ``-(1 - (L/n)^2)`` like P(a). With ``lead_in`` (the profile's ``lead_in_s``) the pattern starts from rest
  (:mod:`ksbo_task.lead_in`) instead of with a 3.5 m/s velocity step; the scored lap 2 is an ordinary lap.

Setpoints carry position + velocity + acceleration (type_mask 0x0C00, frame LOCAL_NED): streamed feed-forward
isolates the position loop from trajectory shaping (fact sheet 4.2). Holds use position-only targets (0x0DF8),
which never time out on the vehicle (fact sheet 4.1 pitfall).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from functools import cached_property
from typing import Any

import numpy as np

from ksbo_mav.profiles import Profile
from ksbo_mav.scoring import ScoreConfig, score_trajectory
from ksbo_mav.smoothness import CUTOFF_HZ, motor_oscillation, smooth_penalty, smoothness
from ksbo_task.figure8_ne import Figure8H

MASK_POS_VEL_ACC = 0x0C00
MASK_POS = 0x0DF8
FRAME_LOCAL_NED = 1
KINDS = {"figure8-xz": "f8", "figure8-ne": "f8h"}
#: Telemetry needed to score a 3-D lap: LOCAL_POSITION_NED at >= 5 Hz (vehicle time), no gap > 0.5 s. The lap's
#: error changes on the figure-8's time scale (20 s period, its harmonics below 1 Hz), so 5 samples a second
#: measure its RMS; a mission flown at 10 Hz over a radio losing a few per cent still scores. A ground station
#: sharing the link may lower the rate we asked for; below this the lap is not scored and the trial is a link
#: problem, not a gain result.
MIN_SCORE_RATE_HZ = 5.0
MAX_SAMPLE_GAP_S = 0.5  # mission type -> tag of the tlog trial markers


@dataclass(frozen=True)
class Mission:
    """A figure-8 in NED. Times are seconds from the trial start ``t0``."""

    kind: str
    scale: float  # m: x amplitude (xz) / north amplitude (ne)
    scale2: float  # m: z amplitude factor (xz, = scale) / east amplitude (ne)
    period: float
    center_up: float
    laps: int
    rate_hz: int
    score_section: tuple[tuple[str, Any], ...] = ()
    lead_in: float = 0.0  # s (figure8-ne): start from rest, ksbo_task.lead_in
    start_speed: float = 0.0  # m/s (figure8-xz): trials start moving, ksbo_mav.mav.approach

    @classmethod
    def from_profile(cls, profile: Profile) -> "Mission":
        """The profile's ``[mission]`` (validated when the profile loaded) with its ``[score]`` overrides."""
        m = profile.mission_spec
        east = m.scale_east_m if m.scale_east_m is not None else m.scale_m
        return cls(m.type, float(m.scale_m), float(east), float(m.period_s), float(m.center_up_m), int(m.laps),
                   int(m.rate_hz), tuple(sorted(profile.score_spec.given().items())), float(m.lead_in_s),
                   float(m.start_speed_mps))

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly fields (stored with a campaign, so that a resume flies the same pattern)."""
        d = asdict(self)
        d["score_section"] = [list(kv) for kv in self.score_section]
        return d

    @property
    def tag(self) -> str:
        return KINDS[self.kind]

    @property
    def dt_ms(self) -> int:
        return 1000 // self.rate_hz

    @property
    def dt(self) -> float:
        return self.dt_ms / 1000.0

    @property
    def steps(self) -> int:
        """Control steps of a complete trial (600 for 2 laps of 6 s at 50 Hz)."""
        return int(round(self.laps * self.period * self.rate_hz))

    @property
    def steps_per_lap(self) -> int:
        return int(round(self.period * self.rate_hz))

    @property
    def window(self) -> tuple[int, int]:
        return self.steps - self.steps_per_lap, self.steps

    def score_config(self) -> ScoreConfig:
        """P(a) constants of the planar task: the profile's ``[score]`` overrides, lap 2 scored."""
        extra = {k: v for k, v in self.score_section if k in ("Q", "R", "u_ref", "j_hi", "lam", "floor")}
        return ScoreConfig(window=self.window, L_expected=self.steps, **extra)

    # --- reference ---------------------------------------------------------------------------------------
    def start_ned(self) -> np.ndarray:
        """(3,) NED position of the figure-8 start (where the vehicle hovers before a trial)."""
        return self.setpoint_at(0.0)[0]

    def setpoint(self, step: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(pos, vel, acc) NED of the reference at ``step`` control periods after the start."""
        return self.setpoint_at(step * self.dt)

    def setpoint_at(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(pos, vel, acc) NED of the reference ``t`` seconds after the start."""
        if self.kind == "figure8-ne":
            return self.figure8h.state(t)
        # figure8-xz: x = A sin wt, z = z0 + A sin wt cos wt = z0 + A/2 sin 2wt (ksbo_task.figure8.Figure8)
        w = 2.0 * math.pi / self.period
        s, c, s2, c2 = math.sin(w * t), math.cos(w * t), math.sin(2 * w * t), math.cos(2 * w * t)
        A = self.scale
        return (np.array([A * s, 0.0, -(self.center_up + A * s * c)]),
                np.array([A * w * c, 0.0, -(A * w * c2)]),
                np.array([-A * w * w * s, 0.0, 2.0 * A * w * w * s2]))

    @cached_property
    def figure8h(self) -> Figure8H:
        """The ``figure8-ne`` pattern as the simulator's :class:`Figure8H` (one implementation of the reference,
        vectorised over time: ``position(t)``, ``velocity(t)``, ``acceleration(t)`` for t of any shape)."""
        if self.kind != "figure8-ne":
            raise ValueError(f"{self.kind} is not a figure8-ne mission")
        return Figure8H(amp_north=self.scale, amp_east=self.scale2, period=self.period, altitude=self.center_up,
                        laps=self.laps, rate_hz=float(self.rate_hz), lead_in=self.lead_in)

    # --- score -------------------------------------------------------------------------------------------
    def lap_smoothness(self, t0_ms: int | None, att: dict[int, Any],
                       motors: dict[float, Any] | None = None) -> dict[str, Any] | None:
        """:func:`ksbo_mav.smoothness.smoothness` of the scored lap's ATTITUDE samples (``att``: {time_boot_ms:
        [roll, pitch, rollspeed, pitchspeed]}) of a trial started at ``t0_ms``, with the
        :func:`~ksbo_mav.smoothness.motor_oscillation` of its SERVO_OUTPUT_RAW samples (``motors``: {vehicle ms:
        the 8 outputs}) where any were recorded; None for the planar task (the paper's P) or without a start."""
        if self.kind == "figure8-xz" or t0_ms is None:
            return None
        lo, hi = self.window
        first, last = t0_ms + (lo + 0.5) * self.dt_ms, t0_ms + (hi + 0.5) * self.dt_ms
        cutoff = float(dict(self.score_section).get("rough_cutoff_hz") or CUTOFF_HZ)

        def lap(d: dict, width: int) -> tuple[np.ndarray, np.ndarray]:
            stamps = sorted(t for t in d if first < t <= last)
            return (np.asarray(stamps, dtype=float) / 1000.0,
                    np.array([d[t] for t in stamps], dtype=float).reshape(-1, width))

        out = smoothness(*lap(att, 4), cutoff)
        if motors:
            out.update(motor_oscillation(*lap(motors, 8), cutoff))
        return out

    def score(self, traj: Any, rms_ref: float | None = None, smooth: dict[str, Any] | None = None,
              rough_ref: float | None = None) -> dict[str, Any]:
        """Score dict of a :class:`ksbo_task.flight.Trajectory` (``P`` first; JSON friendly).

        3-D missions (``figure8-ne``): lap-2 RMS of |measured - commanded| over the samples received, at any
        telemetry rate of at least :data:`MIN_SCORE_RATE_HZ` with no gap longer than :data:`MAX_SAMPLE_GAP_S`.
        ``P = 1 - rms / (ratio * rms_ref)``: ``rms_ref`` is the campaign's baseline RMS (the profile's
        ``[score] rms_ref_m`` if set; a flight with neither is its own reference), ``ratio`` the profile's
        ``unsafe_rms_ratio`` (default 2). So the baseline scores ``1 - 1/ratio`` (0.5) on every vehicle, however
        well it tracks, and P < 0 ("unsafe") means tracking more than ``ratio`` times worse than the baseline.
        ``smooth``: the lap's :func:`ksbo_mav.smoothness.smoothness`, recorded in the score; with the profile's
        ``smooth_weight`` w > 0 and the baseline's roughness ``rough_ref``,
        ``P = 1 - (rms / rms_ref + w max(0, rough - rough_ref - b r) / r) / ratio``, ``r = max(rough_ref, 1
        deg/s)``, b the profile's ``rough_band``.
        """
        if self.kind == "figure8-xz":
            return score_trajectory(traj, self.score_config()).item()
        n, (lo, hi) = self.steps, self.window
        cfg = dict(self.score_section)
        ratio = float(cfg.get("unsafe_rms_ratio", 2.0))
        # The state after step k is stamped (k + 1) dt: lap 2 (steps lo..hi-1) is stamps in ((lo + 0.5) dt,
        # (hi + 0.5) dt].
        t = np.asarray(traj.t, dtype=float)
        sel = (t > (lo + 0.5) * self.dt) & (t <= (hi + 0.5) * self.dt)
        err = traj.states[sel][:, (0, 2, 4)] - traj.refs[sel][:, (0, 2, 4)]
        lap_s = (hi - lo) * self.dt
        count = int(sel.sum())
        rate = count / lap_s
        edges = np.concatenate([[lo * self.dt], t[sel], [hi * self.dt]])
        max_gap = float(np.max(np.diff(edges)))
        reason = ""
        if traj.L < n:
            reason = f"the trial ended after {traj.L} of {n} steps"
        elif rate < MIN_SCORE_RATE_HZ:
            reason = (f"LOCAL_POSITION_NED arrived at {rate:.1f} Hz in the scored lap (minimum "
                      f"{MIN_SCORE_RATE_HZ:g} Hz)")
        elif max_gap > MAX_SAMPLE_GAP_S:
            reason = f"a {max_gap:.2f} s gap in LOCAL_POSITION_NED in the scored lap (at most {MAX_SAMPLE_GAP_S:g} s)"
        elif not np.all(np.isfinite(err)):
            reason = "samples without a logged setpoint in the scored lap"
        complete = not reason
        d = np.sqrt(np.sum(err * err, axis=1)) if count else np.zeros(0)
        rms = float(np.sqrt(np.mean(d * d))) if complete else None
        ref = cfg.get("rms_ref_m", rms_ref)
        ref = float(ref) if ref is not None else rms
        smooth = smooth or {}
        rough = smooth.get("rough_dps")
        penalty = smooth_penalty(rough, rough_ref, float(cfg.get("smooth_weight") or 0.0),
                                 float(cfg.get("rough_band") or 0.0))
        if rms is not None and ref is not None and ref > 0:
            P = 1.0 - (rms / ref + penalty) / ratio
        elif rms is not None:
            P = 1.0
        else:
            P = -(1.0 - (min(traj.L, n) / n) ** 2) if traj.L < n else -1.0 / n
        out = {"P": P, "rms_lap2_m": rms, "rms_ref_m": ref, "unsafe_rms_ratio": ratio, "L": int(traj.L),
               "L_expected": n, "complete": complete, "safe": bool(P >= 0), "samples": count,
               "rate_hz": rate, "max_gap_s": max_gap, "rough_dps": rough, "rough_ref_dps": rough_ref,
               "tilt_max_deg": smooth.get("tilt_max_deg"), "smooth_penalty": penalty}
        for k in ("rough_note", "motor_osc_us", "motor_note"):
            if k in smooth:
                out[k] = smooth[k]
        if complete:
            out["max_err_m"] = float(d.max())
            out["rms_h_m"] = float(np.sqrt(np.mean(np.sum(err[:, :2] ** 2, axis=1))))
            out["rms_v_m"] = float(np.sqrt(np.mean(err[:, 2] ** 2)))
        else:
            out["incomplete"] = reason
        return out


def task_ref(kind: str, ned: np.ndarray) -> np.ndarray:
    """6 task reference states from a setpoint's NED [x, y, z, vx, vy, vz]."""
    if kind == "figure8-xz":
        return np.array([ned[0], ned[3], -ned[2], -ned[5], 0.0, 0.0])
    return np.array([ned[0], ned[3], ned[1], ned[4], -ned[2], -ned[5]])


def task_state(kind: str, ned: np.ndarray, att: np.ndarray) -> np.ndarray:
    """6 task states from LOCAL_POSITION_NED [x, y, z, vx, vy, vz] and ATTITUDE [roll, pitch, rollspeed,
    pitchspeed] (NaN where an attitude sample is missing)."""
    if kind == "figure8-xz":
        return np.array([ned[0], ned[3], -ned[2], -ned[5], -att[1], -att[3]])
    return np.array([ned[0], ned[3], ned[1], ned[4], -ned[2], -ned[5]])
