"""Scoring a flown trial and writing its record.

:func:`score_trial` computes the trial's score from exactly what its tlog holds (so ``ksbo-mav score`` reproduces it)
and decides whom its outcome blames: a lap that could not be measured is the telemetry's doing, a monitor trip right
after the setpoint stream stalled, or a lap flown on late setpoints, is this computer's. :func:`write_record` writes
the JSON record next to the tlog and returns the :class:`~ksbo_task.flight.Flight`.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ksbo_mav.jsonio import dumps, fsync_write
from ksbo_mav.mav.mission import Mission
from ksbo_mav.mav.outcome import TrialOutcome as T
from ksbo_mav.mav.trial_flight import FlownTrial, LinkStats
from ksbo_task.flight import Flight, Trajectory

#: A setpoint sent more than LATE_MS of vehicle time after its step is late; more than MAX_LATE_FRACTION of the
#: scored lap late and the trial measures the client, not the gains (outcome "client", retried by the campaign).
LATE_MS, MAX_LATE_FRACTION = 100.0, 0.02


#: A monitor trip within 2 s of the setpoint stream stalling by more than STALL_MS is the client's doing.
STALL_MS = 500.0


@dataclass(frozen=True)
class ScoredTrial:
    """A flown trial's score and final outcome.

    Attributes:
        trajectory: what the tlog holds (empty when the figure-8 was not reached or not finished).
        info: what the recorder says about it (``L``, ``rms_ref``, ``unfilled`` ...).
        score: the mission's score dict (``P``, ``safe``, ``complete`` ...); an aborted trial is unsafe.
        outcome, message: how the trial ended, after blaming telemetry gaps or a slow client.
        link: the link statistics as recorded (``lost_packets``, ``rate_reasserts``, lateness over the scored lap).
    """

    trajectory: Trajectory
    info: dict[str, Any]
    score: dict[str, Any]
    outcome: T
    message: str
    link: dict[str, Any]


def score_trial(mission: Mission, flown: FlownTrial) -> ScoredTrial:
    """Score ``flown`` against ``mission`` and settle its outcome (see the module docstring)."""
    rec, outcome, message = flown.recorder, flown.outcome, flown.message
    link = link_record(flown.link, mission.window[0])
    if rec.t0 is not None and rec.finished:
        traj, info = rec.trajectory("mavlink")
    else:
        traj, info = _empty_trajectory(), {"L": 0, "outcome": outcome}
    score = mission.score(traj, rms_ref=info.get("rms_ref"), smooth=mission.lap_smoothness(rec.t0, rec.att, rec.motors),
                          rough_ref=info.get("rough_ref"))
    if outcome is T.OK and not score["complete"]:
        # Not the gains' fault: the lap could not be measured. Say why, and whether packets were lost.
        why = score.get("incomplete") or f"telemetry gaps in the scored lap ({info.get('unfilled')})"
        lost = link["lost_packets"]
        cause = (f"{lost} packet(s) lost on the link (sequence gaps)" if lost else
                 "no packet was lost (sequence numbers complete): the vehicle sent less - another ground "
                 "station's stream request, or a saturated link")
        outcome, message = T.TELEMETRY, f"{why}; {cause}"
    stall = stall_before(flown.link.lag_ms, int(traj.L))
    if outcome.gain_caused and stall > STALL_MS:
        # The tuner stopped streaming just before the trip (PX4's OFFBOARD fails safe, ArduPilot dead-reckons
        # the last setpoint): the computer caused it, not the gains.
        outcome, message = T.CLIENT, (f"{message}, {stall:.0f} ms (vehicle time) after the tuner's setpoint "
                                      "stream stalled: this computer could not keep up with the vehicle")
    if outcome is T.OK and link.get("late_fraction", 0.0) > MAX_LATE_FRACTION:
        # The vehicle flew stale setpoints: the tracking error measures this computer, not the gains.
        outcome, message = T.CLIENT, (
            f"{100 * link['late_fraction']:.0f} % of the scored lap's setpoints went out more than "
            f"{LATE_MS:g} ms (vehicle time) late (max {link['lag_max_ms']:.0f} ms): this computer could "
            "not keep up with the vehicle - lower the simulation speed-up or the machine's load")
    if outcome is not T.OK:
        score["P"] = min(float(score["P"]), -1.0 / mission.steps)  # an aborted trial is unsafe, whatever its length
        score["safe"] = False
    return ScoredTrial(traj, info, score, outcome, message, link)


def write_record(stem: Path, index: int, label: str, x: np.ndarray, names: list[str], params: dict[str, float],
                 flown: FlownTrial, scored: ScoredTrial, started: float, extra: dict[str, Any]) -> Flight:
    """Write ``stem``.json (fsynced) for trial ``index`` of gains ``x`` (d,) named ``names``, written as the
    autopilot parameters ``params``; ``started``: wall-clock start (s); ``extra``: further record fields.
    Returns the trial as a :class:`~ksbo_task.flight.Flight` whose ``meta`` is the record without its score."""
    outcome = scored.outcome
    meta = {"trial": index, "label": label, "outcome": outcome.value, "outcome_text": outcome.text,
            "message": scored.message, "restored": flown.restored, "tlog": str(stem.with_suffix(".tlog")),
            "record": str(stem.with_suffix(".json")), "wall_s": time.time() - started,
            "vehicle_values": params, "trajectory": scored.info, "link": scored.link, **extra}
    doc = {"gains": x.tolist(), "names": names, "score": scored.score, **meta}
    fsync_write(stem.with_suffix(".json"), dumps(doc, indent=1))
    return Flight(gains=x, trajectory=scored.trajectory, score=scored.score, outcome=outcome, meta=meta)


def link_record(stats: LinkStats, w: int) -> dict[str, Any]:
    """The record's ``link`` entry: packet loss, rate re-requests and :func:`lag_stats` from scored step ``w``."""
    return {"lost_packets": stats.lost_packets, "rate_reasserts": stats.rate_reasserts,
            **lag_stats(stats.lag_ms, w)}


def stall_before(lag: Sequence[float], L: int, window: int = 100) -> float:
    """Largest setpoint lateness (ms) in the ``window`` steps before step ``L`` (0 when nothing was streamed)."""
    recent = lag[max(0, L - window):L + 1]
    return float(max(recent)) if len(recent) else 0.0


def lag_stats(lag: Sequence[float], w: int) -> dict[str, float]:
    """Setpoint lateness over the scored steps (w..): max, mean, fraction later than LATE_MS."""
    scored = np.asarray(lag[w:], dtype=float)
    if not scored.size:
        return {}
    return {"lag_max_ms": float(scored.max()), "lag_mean_ms": float(scored.mean()),
            "late_fraction": float(np.mean(scored > LATE_MS))}


def _empty_trajectory() -> Trajectory:
    return Trajectory(t=np.zeros(0), steps=np.zeros(0, dtype=int), states=np.zeros((0, 6)), refs=np.zeros((0, 6)),
                      inputs=None, L=0, source="mavlink")
