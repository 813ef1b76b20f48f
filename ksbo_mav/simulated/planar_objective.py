"""The in-process planar simulator as an objective (:class:`SimObjective`), vectorised for optimisers and
benchmarks: it flies gains from the task's starts and returns P(a), or a :class:`ksbo_task.flight.Flight` whose
trajectory is scored the same way as a MAVLink vehicle's (:func:`ksbo_mav.scoring.score_trajectory`).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.profiles import Profile, load_profile
from ksbo_mav.scoring import Score, ScoreConfig, score_rollout, score_trajectory
from ksbo_sim.episode import REASONS, EpisodeConfig, MonitorConfig, Rollout, simulate
from ksbo_sim.plants import Plant, plant as suite_plant
from ksbo_task.flight import Flight, Trajectory
from ksbo_task.limit_checks import Outcome
from ksbo_task.starts import fixed_initial_states, random_initial_states, stress_initial_state


def trajectory_from_rollout(rollout: Rollout, i: int = 0) -> Trajectory:
    """Row ``i`` of a simulator rollout, cut at the last flown step."""
    L = int(rollout.L[i])
    return Trajectory(t=rollout.t[1 : L + 1], steps=np.arange(L), states=rollout.states[i, 1 : L + 1],
                      refs=rollout.refs[1 : L + 1], inputs=rollout.inputs[i, :L], L=L, source="sim")


class SimObjective:
    """The planar simulator as an objective.

    Each call flies one episode from a fresh random initial velocity (a noisy evaluation, as on a real
    vehicle); :meth:`expected` re-flies gains over the fixed initial conditions (the honest value of a
    recommendation). Gains are physical values in the profile's order.

    Args:
        profile: vehicle profile (default ``sim-planar``).
        seed: seed of the initial-velocity generator.
        episode: episode settings; score: P(a) constants.
        chunk: episodes simulated per batch (bounds memory: a batch stores its full trajectories).
        backend: ``"numpy"`` (vectorised, the default) or ``"numba"`` (compiled scalar episodes on all cores;
            faster for large batches, compiles once on first use; nominal plant without monitor only).
        plant: a :class:`ksbo_sim.plants.Plant` or a suite name (``ksbo_sim.plants.PLANTS``); its ``j_hi`` scales
            P unless ``score`` is given.
        monitor: True (the default in-process monitor and backup), a :class:`MonitorConfig`, or False/None (the
            paper's strict mode). With a monitor, calls return :class:`ksbo_mav.opt.evaluation.Evaluation`
            (P and the outcome complete / aborted / crashed) so the optimiser can treat aborts as censored.
    """

    def __init__(self, profile: Profile | str = "sim-planar", seed: int | None = None,
                 episode: EpisodeConfig | None = None, score: ScoreConfig | None = None, chunk: int = 2048,
                 backend: str = "numpy", plant: Plant | str | None = None,
                 monitor: MonitorConfig | bool | None = None) -> None:
        if backend not in ("numpy", "numba"):
            raise InputError(f"backend must be 'numpy' or 'numba', got {backend!r}")
        self.backend = backend
        self.profile = load_profile(profile) if isinstance(profile, str) else profile
        ep = episode or EpisodeConfig()
        if plant is not None:
            try:
                ep = replace(ep, plant=suite_plant(plant) if isinstance(plant, str) else plant)
            except KeyError as exc:
                raise InputError(str(exc.args[0])) from None
        if monitor:
            ep = replace(ep, monitor=monitor if isinstance(monitor, MonitorConfig) else MonitorConfig())
        if backend == "numba" and (ep.plant is not None or ep.monitor is not None):
            raise InputError("the numba backend flies the nominal plant without monitor only")
        self.episode = ep
        j_hi = ep.plant.j_hi if ep.plant is not None else ScoreConfig().j_hi
        self.score_config = score or ScoreConfig(L_expected=self.episode.steps, j_hi=j_hi)
        self.rng = np.random.default_rng(seed)
        self.chunk = chunk
        self.n_episodes = 0

    def _simulate(self, gains: np.ndarray, init: np.ndarray, config: EpisodeConfig) -> Rollout:
        if self.backend == "numba":
            from ksbo_sim.scalar import simulate_parallel

            return simulate_parallel(gains, init, config)
        return simulate(gains, init, config)

    def __call__(self, x: np.ndarray) -> Any:
        """One episode of gains ``x`` (d,): P (strict mode) or an ``Evaluation`` (P, outcome) with a monitor."""
        if self.episode.monitor is None:
            return float(self.batch(np.asarray(x, dtype=float)[None])[0])
        return self.trial(x)

    def trial(self, x: np.ndarray, init: np.ndarray | None = None) -> Any:
        """One episode as an :class:`ksbo_mav.opt.evaluation.Evaluation`: P and complete / aborted / crashed; from a
        random initial velocity unless ``init`` (6,) is given."""
        from ksbo_mav.opt.evaluation import Evaluation

        init = random_initial_states(1, self.rng, self.episode.figure8) if init is None else np.atleast_2d(init)
        r = self.rollout(np.atleast_2d(x), init)
        return Evaluation(float(score_rollout(r, self.score_config).P[0]), r.outcomes[0])

    def rollout(self, X: np.ndarray, init: np.ndarray) -> Rollout:
        """The episodes (trajectories, outcomes) of gains X (n, d) from ``init`` (n, 6), in one batch: for
        :meth:`trial` and diagnostics that need more than the scores."""
        X = np.atleast_2d(self.profile.check_gains(np.asarray(X, dtype=float), within_box=False))
        self.n_episodes += X.shape[0]
        return self._simulate(X, np.atleast_2d(init), self.episode)

    def stress(self, x: np.ndarray) -> Any:
        """One episode of gains ``x`` (d,) from the hardest start (:func:`ksbo_task.starts.stress_initial_state`),
        returned like :meth:`__call__`: the optimisers' re-fly phase may ask for it (``refly_stress``)."""
        init = stress_initial_state(self.episode.figure8)
        if self.episode.monitor is None:
            return float(self.scores(np.atleast_2d(np.asarray(x, dtype=float)), init[None]).P[0])
        return self.trial(x, init)

    def scores(self, X: np.ndarray, init: np.ndarray, with_outcomes: bool = False) -> Any:
        """Score of each row of X (n, d) flown from the matching row of ``init`` (n, 6); with ``with_outcomes``
        also the (n,) list of :class:`ksbo_task.limit_checks.Outcome`."""
        X = np.atleast_2d(self.profile.check_gains(X, within_box=False))
        parts, outcomes = [], []
        for lo in range(0, X.shape[0], self.chunk):
            r = self._simulate(X[lo : lo + self.chunk], init[lo : lo + self.chunk], self.episode)
            parts.append(score_rollout(r, self.score_config))
            outcomes += r.outcomes
        self.n_episodes += X.shape[0]
        return (_concat(parts), outcomes) if with_outcomes else _concat(parts)

    def expected_outcomes(self, X: np.ndarray, inits: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Re-fly like :meth:`expected`; returns (n,) mean P and (n, 3) counts of complete / aborted / crashed."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        inits = fixed_initial_states(figure8=self.episode.figure8) if inits is None else np.atleast_2d(inits)
        n, m = X.shape[0], inits.shape[0]
        sc, outs = self.scores(np.repeat(X, m, axis=0), np.tile(inits, (n, 1)), with_outcomes=True)
        kinds = (Outcome.COMPLETE, Outcome.ABORTED, Outcome.CRASHED)
        counts = np.array([[sum(o is k for o in outs[i * m : (i + 1) * m]) for k in kinds] for i in range(n)])
        return sc.P.reshape(n, m).mean(axis=1), counts

    def batch(self, X: np.ndarray) -> np.ndarray:
        """(n,) P of one episode per row of X (n, d), each from a fresh random initial velocity."""
        X = np.atleast_2d(X)
        init = random_initial_states(X.shape[0], self.rng, self.episode.figure8)
        return self.scores(X, init).P

    def expected(self, X: np.ndarray, inits: np.ndarray | None = None) -> np.ndarray:
        """(n,) mean P over the fixed initial conditions (8, seed 20240611, unless ``inits`` is given)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        inits = fixed_initial_states(figure8=self.episode.figure8) if inits is None else np.atleast_2d(inits)
        n, m = X.shape[0], inits.shape[0]
        P = self.scores(np.repeat(X, m, axis=0), np.tile(inits, (n, 1))).P
        return P.reshape(n, m).mean(axis=1)

    def fly(self, gains: np.ndarray, init: np.ndarray | None = None) -> Flight:
        """Fly one episode and keep its trajectory (for plots, logs and the MAVLink comparison)."""
        gains = self.profile.check_gains(gains, within_box=False)
        init = random_initial_states(1, self.rng, self.episode.figure8)[0] if init is None else np.asarray(init, float)
        r = self._simulate(gains, init, self.episode)
        self.n_episodes += 1
        traj = trajectory_from_rollout(r)
        return Flight(gains=gains, trajectory=traj, score=score_trajectory(traj, self.score_config).item(),
                      outcome=REASONS[int(r.reason[0])], meta={"init": init.tolist()})


def _concat(parts: list[Score]) -> Score:
    if len(parts) == 1:
        return parts[0]
    cat = lambda name: np.concatenate([getattr(p, name) for p in parts])  # noqa: E731
    return Score(P=cat("P"), JQ=cat("JQ"), JR=cat("JR"), JR_scaled=cat("JR_scaled"), L=cat("L"),
                 L_expected=parts[0].L_expected, complete=cat("complete"))
