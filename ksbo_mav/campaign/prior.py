"""The kernel-selection prior of a campaign: simulator episodes around the baseline (computed once, kept in
``prior.json``), or a local Latin hypercube flown on the vehicle (journalled as ``prior`` trials)."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

import numpy as np

from ksbo_mav.campaign.config import CampaignConfig, prior_size
from ksbo_mav.campaign.layout import CampaignDir, write_file


def campaign_prior(kind: str, cfg: CampaignConfig, d: CampaignDir, profile: Any, x0: np.ndarray, bounds: np.ndarray,
                   flown: list[float], fly: Callable[[np.ndarray], float],
                   log: Callable[[str], None]) -> tuple[np.ndarray, np.ndarray] | None:
    """``(X (n, d), y (n,))`` or None for ``kind`` "none". ``flown``: P of the prior trials already journalled
    (a resumed campaign flies only the rest, through ``fly``)."""
    if kind == "none":
        return None
    if kind == "sim":
        if d.prior.exists():
            doc = json.loads(d.prior.read_text())
            return np.array(doc["X"]), np.array(doc["y"])
        n = prior_size(cfg, kind)
        X = local_prior_design(n, x0, bounds, cfg.seed, radius=SIM_PRIOR_RADIUS)
        what, y = simulated_prior(profile, X, cfg.seed, log, trial_step=bool(cfg.trial_step))
        write_file(d.prior, json.dumps({"kind": "sim", "X": X.tolist(), "y": y.tolist()}))
        log(f"prior: {n} {what} episodes around the baseline (in process, nothing flown)")
        return X, y
    n = prior_size(cfg, kind)
    X = local_prior_design(n, x0, bounds, cfg.seed)
    y = list(flown)
    for k in range(len(y), n):
        log(f"prior trial {k + 1}/{n} (local LHS around the baseline)")
        y.append(fly(X[k]))
    return X, np.array(y)


def simulated_prior(profile: Any, X: np.ndarray, seed: int, log: Callable[[str], None],
                    trial_step: bool = False) -> tuple[str, np.ndarray]:
    """(name of the simulator, (n,) P of each row of X (n, d)) flown in process: the planar simulator for the
    planar profile, our JSBSim copter for the copter profiles (the vehicle class the profile names; P scored
    against its own baseline flight, as on the vehicle; with ``trial_step`` each episode flies the campaign's
    position step too). An aborted or crashed episode gives the P of an abort (-0.1) so that the model sees where
    the simulated vehicle failed."""
    from ksbo_mav.simulated.copter_objective import COPTER_PLANTS

    plant = next((k for k, (name, _) in COPTER_PLANTS.items() if name == profile.name), None)
    if plant is None:
        from ksbo_mav.simulated.planar_objective import SimObjective

        return "simulator", SimObjective(profile, seed=seed).batch(X)
    from ksbo_mav.simulated.copter_objective import CopterObjective

    obj = CopterObjective(plant, trial_step=trial_step)
    y = []
    for k, x in enumerate(X):
        if k % 8 == 0:
            log(f"prior: simulating {k + 1}-{min(k + 8, len(X))} of {len(X)} on the JSBSim copter")
        e = obj(x)
        y.append(e.value if e.value is not None and e.outcome.value == "complete" else -0.1)
    return "JSBSim copter", np.asarray(y, dtype=float)


#: Half-widths (unit cube of the optimiser box) of the priors around the baseline: flown (``--prior local``) and
#: simulated (``--prior sim``, free, so it may range wider).
LOCAL_PRIOR_RADIUS = 0.1
SIM_PRIOR_RADIUS = 0.25


def local_prior_design(n: int, x0: np.ndarray, bounds: np.ndarray, seed: int,
                       radius: float = LOCAL_PRIOR_RADIUS) -> np.ndarray:
    """(n, d) prior gains: a Latin hypercube within ``radius`` of the baseline ``x0`` (d,) in the optimiser box
    ``bounds`` (d, 2); by default the flown local prior (``--prior local``)."""
    from ksbo_mav.select.design import lhs_design

    lo, hi = bounds[:, 0], bounds[:, 1]
    u0 = (x0 - lo) / (hi - lo)
    return lo + lhs_design(n, len(x0), "local", center=u0, radius=radius, seed=seed) * (hi - lo)
