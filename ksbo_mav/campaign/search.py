"""Safe BO over flown trials: the optimiser asks, the trial loop flies; a resumed campaign answers the journalled
trials from the journal (:class:`~ksbo_mav.campaign.replay.JournalReplay`) and flies only new ones."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ksbo_mav.campaign.config import CampaignConfig, optimizer_options, prior_kind
from ksbo_mav.campaign.journal import JournalEntry
from ksbo_mav.campaign.replay import JournalReplay
from ksbo_mav.campaign.trials import TrialLoop
from ksbo_mav.errors import UnsafeStartError, VehicleError
from ksbo_mav.mav.approach import moving_starts


def search(trials: TrialLoop, cfg: CampaignConfig, x0: np.ndarray, bounds: np.ndarray, prior: Any,
           resume: bool, log: Callable[[str], None]) -> tuple[Any, list[JournalEntry]]:
    """Run the optimiser over ``bounds`` (d, 2) from ``x0`` (d,) with the ``prior`` (X, y) or None. Returns its
    result and the journalled trials a diverged replay could not use."""
    from ksbo_mav import optimize

    done = trials.journal.of("opt")
    m = trials.objective.mission  # a stress start exists only with moving starts
    profile = trials.objective.profile
    replay = JournalReplay(done, trials.evaluate, log, (lambda x: trials.evaluate(x, stress=True))
                           if moving_starts(m.kind, m.start_speed) else None)
    if resume and len(done) > 1:
        log(f"resume: replaying {len(done)} journalled trial(s) through the optimiser (nothing re-flown)")
    try:
        result = optimize(replay, x0, bounds, prior=prior, budget=cfg.budget, method=cfg.method,
                          seed=cfg.seed, p_min=0.0, check_x0=True,
                          **optimizer_options(prior_kind(cfg, profile), cfg.options, cfg.method, profile))
    except UnsafeStartError:
        raise VehicleError(f"the baseline gains flew unsafe (P = {done[0].P:.3f} < 0): safe BO needs a safe "
                           "start; fix the gains or the mission/safety settings first (baseline restored)"
                           ) from None
    return result, replay.unused
