"""The paper's performance measure P(a), independent of where a trajectory came from.

    J^Q = 1/2 sum (x_i - x_i^ref)^T Q (x_i - x_i^ref) + 1/2 sum (u_i - u^ref)^T R (u_i - u^ref)
    J^R = -J^Q,   J^R_scaled = max(1 + J^R / J_HI, floor)   (0 when the scored window was not completed)
    P(a) = J^R_scaled - (1 - lambda (L / L_expected)^2)

Samples are pairs (state after control step k, reference at the same time, input applied in step k) tagged
with their step index k; the in-process simulator, MAVLink telemetry and offline logs all produce them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_task.flight import Trajectory


def _default_q() -> tuple[float, ...]:
    return (1.0, 0.1, 1.0, 0.1, 0.1, 0.1)


@dataclass(frozen=True)
class ScoreConfig:
    """Constants of P(a). Defaults: shared fact sheet part C (SCG LQR weights, lap 2 of 600 steps, J_HI 5.6).

    Attributes:
        Q: diagonal state weights for [x, vx, z, vz, theta, theta_dot].
        R: diagonal input weights for [T1, T2].
        u_ref: reference input per motor pair (N); SCG uses m g / 2.
        window: [start, stop) control steps whose cost is summed (lap 2 = steps 300..599).
        L_expected: control steps of a complete episode.
        j_hi: J^Q that maps to J^R_scaled = 0 (1.25 x J^Q of the default safe gains).
        lam: lambda of the incomplete-tracking penalty.
        floor: lower limit of J^R_scaled for complete episodes.
    """

    Q: tuple[float, ...] = field(default_factory=_default_q)
    R: tuple[float, float] = (0.1, 0.1)
    u_ref: float = 0.027 * 9.8 / 2.0
    window: tuple[int, int] = (300, 600)
    L_expected: int = 600
    j_hi: float = 5.6
    lam: float = 1.0
    floor: float = -1.0

    def __post_init__(self) -> None:
        if len(self.Q) != 6 or len(self.R) != 2:
            raise InputError("Q needs 6 diagonal weights and R needs 2")
        if not (0 <= self.window[0] < self.window[1]):
            raise InputError(f"score window {self.window} must satisfy 0 <= start < stop")
        if self.L_expected <= 0 or self.j_hi <= 0:
            raise InputError("L_expected and j_hi must be positive")


@dataclass
class Score:
    """Score of B trajectories (all fields are arrays of shape (B,), or scalars for B = 1 via :meth:`item`).

    JQ is NaN when the scored window was not completed (an early stop has no comparable tracking cost).
    """

    P: np.ndarray
    JQ: np.ndarray
    JR: np.ndarray
    JR_scaled: np.ndarray
    L: np.ndarray
    L_expected: int
    complete: np.ndarray

    @property
    def safe(self) -> np.ndarray:
        """P >= 0 (P_min = 0): the paper's safety criterion."""
        return self.P >= 0.0

    def item(self, i: int = 0) -> dict:
        """Plain-Python dict of trajectory ``i`` (JSON friendly; NaN becomes None)."""
        def val(a):
            v = np.asarray(a)[i].item()
            return None if isinstance(v, float) and not np.isfinite(v) else v
        return {"P": val(self.P), "JQ": val(self.JQ), "JR": val(self.JR), "JR_scaled": val(self.JR_scaled),
                "L": int(np.asarray(self.L)[i]), "L_expected": int(self.L_expected),
                "complete": bool(np.asarray(self.complete)[i]), "safe": bool(self.safe[i])}


def stage_costs(states: np.ndarray, refs: np.ndarray, inputs: np.ndarray | None,
                config: ScoreConfig = ScoreConfig()) -> np.ndarray:
    """Per-sample cost 1/2 dx^T Q dx + 1/2 du^T R du.

    Args:
        states: (B, n, 6); refs: (n, 6) or (B, n, 6); inputs: (B, n, 2) or None (input term omitted).
    Returns:
        (B, n) costs (NaN where a sample is NaN).
    """
    dx = states - refs
    cost = 0.5 * np.einsum("...i,i,...i->...", dx, np.asarray(config.Q), dx)
    if inputs is not None:
        du = inputs - config.u_ref
        cost = cost + 0.5 * np.einsum("...i,i,...i->...", du, np.asarray(config.R), du)
    return cost


def score(states: np.ndarray, refs: np.ndarray, steps: np.ndarray, L: np.ndarray | int,
          inputs: np.ndarray | None = None, config: ScoreConfig = ScoreConfig()) -> Score:
    """Score B trajectories.

    Args:
        states: (B, n, 6) or (n, 6) states, sample i taken after control step ``steps[i]``.
        refs: (n, 6) or like ``states``: reference state at the same instants.
        steps: (n,) integer control-step index of each sample.
        L: (B,) or scalar: control steps flown (L < L_expected = early stop).
        inputs: optional (B, n, 2) thrusts applied during each step.
    """
    states = np.asarray(states, dtype=float)
    if states.ndim == 2:
        states = states[None]
        inputs = None if inputs is None else np.asarray(inputs, dtype=float)[None]
    refs = np.asarray(refs, dtype=float)
    steps = np.asarray(steps)
    if states.shape[-1] != 6 or refs.shape[-1] != 6 or steps.shape != (states.shape[1],):
        raise InputError(f"inconsistent trajectory shapes: states {states.shape}, refs {refs.shape}, "
                         f"steps {steps.shape}")
    B = states.shape[0]
    L = np.broadcast_to(np.asarray(L, dtype=np.int64), (B,)).copy()
    lo, hi = config.window
    in_window = (steps >= lo) & (steps < hi)
    cost = stage_costs(states[:, in_window], refs[..., in_window, :] if refs.ndim == 3 else refs[in_window],
                       None if inputs is None else inputs[:, in_window], config)
    # The window is complete when every one of its steps was flown and sampled with finite values.
    have_all = np.isin(np.arange(lo, hi), steps[in_window]).all()
    complete = (L >= hi) & have_all & np.all(np.isfinite(cost), axis=1)
    JQ = np.where(complete, np.nansum(cost, axis=1), np.nan)
    JR = -JQ
    JR_scaled = np.where(complete, np.maximum(1.0 + JR / config.j_hi, config.floor), 0.0)
    penalty = 1.0 - config.lam * (L / config.L_expected) ** 2
    P = JR_scaled - penalty
    return Score(P=P, JQ=JQ, JR=JR, JR_scaled=JR_scaled, L=L, L_expected=config.L_expected, complete=complete)


def score_rollout(rollout, config: ScoreConfig = ScoreConfig()) -> Score:
    """Score a :class:`ksbo_sim.episode.Rollout` (state after step k vs X_GOAL[k+1], input of step k)."""
    n = rollout.inputs.shape[1]
    return score(rollout.states[:, 1:], rollout.refs[1:], np.arange(n), rollout.L, rollout.inputs, config)


def score_trajectory(traj: Trajectory, config: ScoreConfig = ScoreConfig()) -> Score:
    """Score one :class:`ksbo_task.flight.Trajectory` (from the simulator, a vehicle's telemetry or a log)."""
    return score(traj.states, traj.refs, traj.steps, traj.L, traj.inputs, config)
