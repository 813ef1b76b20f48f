"""The JSBSim 3-D copter as an in-process objective (a benchmark plant): fly a gain vector, return P and how
the flight ended.

It scores exactly like a MAVLink campaign on the same vehicle profile (``ardupilot-copter`` or ``px4-copter``):
lap-2 RMS tracking error of the horizontal figure-8, ``P = 1 − RMS / (unsafe_rms_ratio · RMS_baseline)`` with the
baseline flown once at construction, so the baseline scores 0.5. The profile's ``[safety]`` limits are checked on
every sample by the shared monitor code (:func:`ksbo_task.limit_checks.check_state`): a flight that trips them is
*aborted* (the tuner would stop it and restore the baseline; the backup's recovery itself is not simulated in
process), one the simulator reports as crashed is *crashed*. The JSBSim model is deterministic: re-flying the same
gains gives the same P (a SITL's repeat noise is a few per cent of RMS). With ``trial_step`` each flight also flies
the campaign's position step after the figure-8 (:mod:`ksbo_mav.mav.trial_step`: hold the end point for the
settle, then the single position target for the dwell), aborted when it leans past the step's tilt limit, so a
simulated prior shows the optimiser where the flown trials would abort on the step.

Search box: the profile box intersected with the campaign's trust region around the baseline
(:func:`ksbo_mav.mav.gains.trust_region`), i.e. where ``ksbo-mav tune`` would let a trial go.
"""

from __future__ import annotations

import math

import numpy as np

from ksbo_mav.mav.gains import opt_bounds
from ksbo_mav.mav.mission import Mission
from ksbo_mav.mav.monitor import limits_from_profile
from ksbo_mav.mav.trial_step import TrialStep, lean_deg
from ksbo_mav.opt.evaluation import Evaluation, Outcome
from ksbo_mav.profiles import Profile, load_profile
from ksbo_task.limit_checks import check_state

#: Copter plants of the suite: name → (vehicle profile, simulator personality).
COPTER_PLANTS: dict[str, tuple[str, str]] = {
    "copter3d-ardupilot": ("ardupilot-copter", "ardupilot"),
    "copter3d-px4": ("px4-copter", "px4"),
}


class CopterObjective:
    """``obj(x)`` → :class:`Evaluation` of gains x (d,) in the profile's order (see the module docstring).

    Attributes:
        profile: the vehicle profile; bounds: (d, 2) the search box; baseline: (d,) profile defaults;
        rms_ref: lap-2 RMS (m) of the baseline; n_flights: flights flown so far.
    """

    def __init__(self, plant: str = "copter3d-ardupilot", trial_step: bool = False, settle_s: float = 1.0) -> None:
        from ksbo_sim.copter3d import Copter3D

        try:
            profile_name, personality = COPTER_PLANTS[plant]
        except KeyError:
            raise KeyError(f"unknown copter plant {plant!r}; known: {', '.join(COPTER_PLANTS)}") from None
        self.plant = plant
        self.profile: Profile = load_profile(profile_name)
        self.vehicle = Copter3D(personality)
        self.figure = Mission.from_profile(self.profile).figure8h  # the campaign's mission, lead-in included
        self.limits = limits_from_profile(self.profile)
        self.ratio = float(self.profile.score_spec.unsafe_rms_ratio)
        self.step = TrialStep.from_profile(self.profile, self.limits) if trial_step else None
        self.settle_s = settle_s
        self.baseline = np.asarray(self.profile.default, dtype=float)
        self.bounds = opt_bounds(self.profile, self.baseline)
        self.n_flights = 0
        self.rms_ref = math.nan
        base = self.flight(self.baseline)
        if base[1] is not Outcome.COMPLETE:
            raise RuntimeError(f"{plant}: the baseline gains did not complete the figure-8 ({base[1].value})")
        self.rms_ref = base[0]

    def flight(self, x: np.ndarray) -> tuple[float, Outcome, str]:
        """Fly gains x (d,): (lap-2 RMS in m or NaN, outcome, monitor message or "")."""
        from ksbo_sim.copter3d import fly

        x = self.profile.check_gains(np.asarray(x, dtype=float), within_box=False)
        for name, v in zip(self.profile.names, x):
            self.vehicle.set_param(name, float(v))
        f = fly(self.vehicle, self.figure)
        self.n_flights += 1
        if f.crashed:
            return math.nan, Outcome.CRASHED, f"simulator crash code {f.crashed}"
        ref = self.figure.position(f.t)
        tilt = math.radians(f.max_tilt_deg) if np.isfinite(f.max_tilt_deg) else None
        # fly() keeps positions per sample but only the flight's largest tilt, so the tilt limit is judged once
        # (with the first sample) and the fence and tracking limits on every sample.
        for k in range(f.pos.shape[0]):
            n, e, d = f.pos[k]
            hit = check_state(self.limits, float(n), float(e), float(-d), tilt if k == 0 else None,
                              (float(ref[k, 0]), float(ref[k, 1]), float(-ref[k, 2])))
            if hit is not None:
                return float(f.rms_lap2), Outcome.ABORTED, hit[1]
        lean = self._step_lean()
        if lean is not None and lean > self.step.tilt_max_deg:
            return float(f.rms_lap2), Outcome.ABORTED, f"position step after the figure-8: tilt {lean:.1f} deg"
        return float(f.rms_lap2), Outcome.COMPLETE, ""

    def _step_lean(self) -> float | None:
        """With a trial step: fly it on from where the figure-8 left the vehicle (the end point held for the
        settle, then the step's target for its dwell, position-only setpoints); its largest lean (deg)."""
        if self.step is None:
            return None
        from ksbo_sim.vehicle import Setpoint

        end = self.figure.state(float(self.figure.duration))[0]
        target = np.asarray(end, float) + np.asarray(self.step.offset_ned, float)
        dt = self.vehicle.ctrl_dt
        for _ in range(int(round(self.settle_s / dt))):
            self.vehicle.step(Setpoint(pos=np.asarray(end, float)))
        peak = 0.0
        for _ in range(int(round(self.step.dwell_s / dt))):
            st = self.vehicle.step(Setpoint(pos=target))
            peak = max(peak, lean_deg(float(st.rpy[0]), float(st.rpy[1])))
        return peak

    def score(self, rms: float) -> float:
        """P of a lap-2 RMS (module docstring)."""
        return 1.0 - rms / (self.ratio * self.rms_ref)

    def __call__(self, x: np.ndarray) -> Evaluation:
        rms, outcome, _ = self.flight(x)
        return Evaluation(self.score(rms) if np.isfinite(rms) else None, outcome)

    def expected_outcomes(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Re-fly each row of X (n, d) once (deterministic): (n,) P (NaN if not complete), (n, 3) counts of
        complete / aborted / crashed — the same shape as
        :meth:`ksbo_mav.simulated.planar_objective.SimObjective.expected_outcomes`."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        P = np.full(X.shape[0], np.nan)
        counts = np.zeros((X.shape[0], 3), dtype=int)
        kinds = (Outcome.COMPLETE, Outcome.ABORTED, Outcome.CRASHED)
        for i, x in enumerate(X):
            rms, outcome, _ = self.flight(x)
            counts[i, kinds.index(outcome)] = 1
            if outcome is Outcome.COMPLETE:
                P[i] = self.score(rms)
        return P, counts
