"""Widening the search box where the campaign's best gains end on its edge (``tune --widen``, or the profile's
``[trust_region] widen = true``).

After the search, when the recommendation (or the best flown trial) sits on a bound of the box and the gain's
documented range (``[[gains]] range_min``/``range_max``: the autopilot's own range for the parameter; without them
the profile's ``min``/``max``) reaches further, that bound moves out by ``widen_step`` of the box's width, capped at
the documented range. The optimiser then runs again on the wider box along the gains whose bounds moved (the others
held at the recommendation: a few trials could not search every gain, and the question is whether the improvement
continues past that bound), warm-started with the campaign's flights near the recommendation (``prior=``) and
started from the recommendation, which it re-flies first: its safe set grows into the new region only from
certified points, as it did in the old box. Up to ``widen_steps`` steps of ``widen_trials`` optimiser trials each.

Every step is journalled in ``widen.jsonl`` (one fsynced line: the new box, the bounds that moved, how many
optimiser trials came before it) before any trial is flown in it, so a resumed campaign replays the same boxes.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ksbo_mav.campaign.box_edge import edge_hits
from ksbo_mav.campaign.layout import CampaignDir, append_line
from ksbo_mav.errors import InputError

#: Optimiser options of a widening stage (over the campaign's): a stage is a few trials, so at most its last one
#: re-flies a candidate (ksbo-adaptive's default re-flies its last 9), and no trust region around the incumbent
#: (its initial 0.1 of the box would not reach the new part; the certificate still bounds each step).
STAGE_OPTIONS = {"refly_last": 1, "trust_region": False}


def documented_range(profile: Any) -> np.ndarray:
    """(d, 2) how far a gain may ever go: ``range_min``/``range_max`` of its ``[[gains]]`` row, else its min/max."""
    return np.array([[float(g.extra.get("range_min", g.min)), float(g.extra.get("range_max", g.max))]
                     for g in profile.gains], dtype=float)


@dataclass(frozen=True)
class Move:
    """One bound of one gain moved out: ``side`` "lower"/"upper", ``old`` → ``new``, ``limit`` the documented end."""

    name: str
    side: str
    old: float
    new: float
    limit: float

    def message(self) -> str:
        cap = " (its documented range ends there)" if np.isclose(self.new, self.limit) else \
            f" (documented range ends at {self.limit:.4g})"
        return f"widened: {self.name} {self.side} bound {self.old:.4g} -> {self.new:.4g}{cap}"


@dataclass(frozen=True)
class WidenStep:
    """One journalled widening: the box after it (optimiser units), what moved, and the optimiser trials before it."""

    step: int
    after_opt: int
    bounds: list[list[float]]
    moves: list[Move]

    def to_json(self) -> str:
        return json.dumps({"step": self.step, "after_opt": self.after_opt, "bounds": self.bounds,
                           "moves": [dataclasses.asdict(m) for m in self.moves]})

    @classmethod
    def parse(cls, doc: Any, where: str) -> "WidenStep":
        try:
            return cls(int(doc["step"]), int(doc["after_opt"]), [[float(a), float(b)] for a, b in doc["bounds"]],
                       [Move(**m) for m in doc["moves"]])
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"{where}: not a widening step ({exc})") from None


def read_steps(d: CampaignDir) -> list[WidenStep]:
    """The journalled widening steps of the campaign in ``d`` (none when it never widened)."""
    path = d.widen_log
    if not path.exists():
        return []
    lines = [ln for ln in path.read_text().splitlines() if ln.strip()]
    steps = []
    for n, line in enumerate(lines, 1):
        try:
            doc = json.loads(line)
        except json.JSONDecodeError:
            if n == len(lines):  # half-written by a killed process: that step never flew a trial
                break
            raise InputError(f"{path}:{n}: corrupt line") from None
        steps.append(WidenStep.parse(doc, f"{path}:{n}"))
    return steps


def append_step(d: CampaignDir, step: WidenStep) -> None:
    append_line(d.widen_log, step.to_json())


def next_box(x: np.ndarray, best: np.ndarray | None, bounds: np.ndarray, limits: np.ndarray, names: list[str],
             step: float) -> tuple[np.ndarray, list[Move]]:
    """The box with every bound that ``x`` (the recommendation) or ``best`` (the best flown gains) touches moved
    out by ``step`` of that gain's width, capped at ``limits``; the moves (none: nothing to widen)."""
    new = np.array(bounds, dtype=float)
    moves: list[Move] = []
    touched = {(h.name, h.side) for p in (x, best) if p is not None for h in edge_hits(p, bounds, names)}
    for i, name in enumerate(names):
        width = bounds[i, 1] - bounds[i, 0]
        for side, j, sign in (("lower", 0, -1.0), ("upper", 1, 1.0)):
            if (name, side) not in touched:
                continue
            target = bounds[i, j] + sign * step * width
            target = max(target, limits[i, 0]) if side == "lower" else min(target, limits[i, 1])
            if abs(target - bounds[i, j]) > 1e-9 * max(width, 1e-12):
                new[i, j] = target
                moves.append(Move(name, side, float(bounds[i, j]), float(target), float(limits[i, j])))
    return new, moves


def box_profile(profile: Any, bounds: np.ndarray) -> Any:
    """``profile`` whose box is exactly ``bounds`` (d, 2) and whose trust region is that box: what the vehicle's
    gain service checks every trial against once the box is widened."""
    from ksbo_mav.profile_sections import TrustRegion

    gains = tuple(dataclasses.replace(g, min=float(lo), max=float(hi)) for g, (lo, hi) in zip(profile.gains, bounds))
    return dataclasses.replace(profile, gains=gains, trust_region=TrustRegion())


def campaign_data(opt: list[Any], prior: tuple[np.ndarray, np.ndarray] | None) -> tuple[np.ndarray, np.ndarray]:
    """(X, y): the ``prior`` and the optimiser trials ``opt`` (journal entries). A trial the monitor aborted or that
    crashed enters with P at most 0: the optimiser's prior has no outcomes, and what it must learn from one is that
    the gains were not safe there."""
    X = [np.asarray(prior[0], dtype=float)] if prior is not None else []
    y = [np.asarray(prior[1], dtype=float)] if prior is not None else []
    if opt:
        X.append(np.array([e.x for e in opt], dtype=float))
        y.append(np.array([e.P if e.outcome == "ok" else min(e.P, 0.0) for e in opt], dtype=float))
    dim = len(opt[0].x) if opt else (np.asarray(prior[0]).shape[1] if prior is not None else 0)
    return (np.vstack(X) if X else np.zeros((0, dim))), (np.concatenate(y) if y else np.zeros(0))


def widen_search(trials: Any, cfg: Any, vehicle: Any, d: CampaignDir, bounds: np.ndarray, prior: Any,
                 result: Any, unused: list, log: Callable[[str], None]) -> tuple[Any, list, np.ndarray]:
    """Widen the box while the recommendation ends on a bound that may move (see the module docstring). Returns
    the final (result, unused journal entries, bounds)."""
    from ksbo_mav.campaign.search import search_box

    tr = vehicle.profile.trust_region
    limits, names = documented_range(vehicle.profile), vehicle.profile.names
    done = read_steps(d)
    for k in range(tr.widen_steps):
        opt = trials.journal.of("opt")
        if k < len(done):
            step = done[k]
        else:
            ok = [e for e in opt if e.outcome == "ok"]
            best = np.asarray(max(ok, key=lambda e: e.P).x) if ok else None
            new, moves = next_box(np.asarray(result.x, dtype=float), best, bounds, limits, names, tr.widen_step)
            if not moves:
                if edge_hits(result.x, bounds, names):
                    log("widen: the recommendation is on a bound that is the end of the gain's documented range; "
                        "not widened")
                return result, unused, bounds
            step = WidenStep(k + 1, len(opt), np.asarray(new).tolist(), moves)
            append_step(d, step)
        for m in step.moves:
            log(f"search box {m.message()}")
        bounds = np.asarray(step.bounds, dtype=float)
        vehicle.tuning.profile = box_profile(vehicle.profile, bounds)
        X, y = campaign_data(opt[:step.after_opt], prior)
        log(f"widen step {step.step}: {tr.widen_trials} trials along the widened gain(s) from the recommendation "
            "(re-flown first), the others held; the campaign's flights near it as the optimiser's prior")
        new_result, more = search_box(trials, cfg, np.asarray(result.x, dtype=float), bounds, (X, y),
                                      trials.journal.of("opt")[step.after_opt:], tr.widen_trials, log,
                                      dims=sorted({names.index(m.name) for m in step.moves}), **STAGE_OPTIONS)
        if new_result is None:  # the recommendation no longer flies safe: keep what the last box gave
            return result, unused, bounds
        result, unused = new_result, unused + more
    return result, unused, bounds
