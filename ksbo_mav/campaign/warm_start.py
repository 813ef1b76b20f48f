"""A campaign warm-started from a finished one (``tune DIR --warm-start EARLIER``): its flights become the
optimiser's prior, its recommendation is re-flown first, and the search goes on from there.

Only a campaign on the same vehicle (identity) or with the same profile, tuning the same gains, may start another;
anything else is refused before a trial is flown. No flown prior: the earlier campaign's flights are the prior.

Order of flights: the baseline (as in every campaign: the reference every 3-D score is measured against), the
earlier recommendation (so the vehicle's current condition is known: the console compares its lap RMS with the
earlier confirmation's), then ``--budget`` - 1 optimiser trials from it, in the earlier campaign's final box.

3-D scores are relative to the baseline flight's lap RMS: the earlier campaign's scores are put on this campaign's
scale with the two baselines' RMS (``P' = 1 - (1 - P) * RMS_ref_earlier / RMS_ref_now``), so a vehicle that now
flies its baseline worse (wind added) is compared fairly. The optimiser still learns from the earlier flights as
measured then; when the re-flight shows the vehicle changed, the console says so and by how much.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ksbo_mav.campaign.journal import Journal
from ksbo_mav.campaign.layout import CampaignDir
from ksbo_mav.errors import InputError

#: Optimiser options of a warm start (over the campaign's): at most its last trial re-flies a candidate (ksbo-adaptive's
#: default re-flies its last 9: the earlier flights already decided between the well-flown candidates), and no trust
#: region around the incumbent (its initial 0.1 of the box would hold the search at the earlier recommendation).
STAGE_OPTIONS = {"refly_last": 1, "trust_region": False}

#: A re-flight of the earlier recommendation whose lap RMS differs from the earlier confirmation's by more than
#: this fraction (or its P by more than this) says the vehicle changed.
CHANGED = 0.15


class Earlier:
    """The finished campaign a warm start reads: settings, journal, recommendation and final box."""

    def __init__(self, path: str) -> None:
        self.d = CampaignDir.at(path)
        self.settings = self.d.read_settings()
        self.result = self.d.read_result()
        self.journal = Journal(self.d.journal)
        grown = self.result.get("box") or {}
        self.bounds = np.asarray(grown.get("bounds") or self.settings["bounds"], dtype=float)
        self.x = np.asarray(self.result["best"]["x"], dtype=float)
        opt = self.journal.of("opt")
        self.rms_ref = opt[0].rms if opt else None
        conf = [e for e in self.journal.of("confirm") if e.outcome == "ok"]
        self.confirm_rms = float(np.mean([e.rms for e in conf])) if conf and conf[0].rms is not None else None
        self.confirm_P = float(np.mean([e.P for e in conf])) if conf else None

    def check_matches(self, vehicle: Any) -> None:
        """InputError (one line) unless the vehicle runs the same profile, or is the same vehicle, with the same
        tuned gains."""
        names = list(self.settings["baseline"])
        same_profile = self.settings["profile"] == vehicle.profile.name
        same_vehicle = self.settings.get("identity") == vehicle.identity.to_dict()
        if names != list(vehicle.gain_map.param_names) or not (same_profile or same_vehicle):
            raise InputError(f"--warm-start {self.d.root}: that campaign tuned {', '.join(names)} with profile "
                             f"{self.settings['profile']}; this one tunes {', '.join(vehicle.gain_map.param_names)} "
                             f"with {vehicle.profile.name} on another vehicle: a warm start needs the same profile "
                             "or vehicle and the same gains")

    def data(self, rms_ref: float | None) -> tuple[np.ndarray, np.ndarray]:
        """(X, y): the earlier campaign's flown prior, optimiser trials and confirmations, scores on the scale of a
        baseline flying ``rms_ref`` now."""
        ratio = self.rms_ref / rms_ref if self.rms_ref and rms_ref else 1.0
        entries = [e for e in self.journal.entries if e.kind in ("opt", "prior", "confirm")]
        X, y = campaign_data(entries)
        return X, 1.0 - (1.0 - y) * ratio


def campaign_data(entries: list[Any]) -> tuple[np.ndarray, np.ndarray]:
    """(X, y) of the flown trials ``entries`` (journal entries). A trial the monitor aborted or that crashed enters
    with P at most 0: the optimiser's prior has no outcomes, and what it must learn from one is that the gains were
    not safe there."""
    X = np.array([e.x for e in entries], dtype=float) if entries else np.zeros((0, 0))
    y = np.array([e.P if e.outcome == "ok" else min(e.P, 0.0) for e in entries], dtype=float)
    return X, y


def warm_search(trials: Any, cfg: Any, vehicle: Any, x0: np.ndarray, log: Callable[[str], None]
                ) -> tuple[Any, Any, list]:
    """(prior, optimiser result, unused journal entries) of a warm-started campaign (the baseline is flown): the
    search starts in the earlier campaign's final box (grown further where the profile says so)."""
    from ksbo_mav.campaign.search import search_box

    earlier = Earlier(cfg.warm_start)
    box = earlier.bounds
    if np.any(x0 < box[:, 0] - 1e-9) or np.any(x0 > box[:, 1] + 1e-9):
        raise InputError(f"--warm-start {cfg.warm_start}: the vehicle's gains lie outside that campaign's search "
                         "box; restore its baseline (ksbo-mav restore) or start a new campaign")
    opt = trials.journal.of("opt")
    ref = opt[0].rms
    X, y = earlier.data(ref)
    prior = (np.vstack([X, [opt[0].x]]), np.append(y, opt[0].P))
    log(f"warm start: {len(y)} flights of {earlier.d.root} as the prior; re-flying its recommendation first")
    if len(opt) < 2:
        trials.evaluate(earlier.x)
    again = trials.journal.of("opt")[1]
    say_condition(earlier, again, log)
    result, unused = search_box(trials, cfg, earlier.x, box, prior, trials.journal.of("opt")[1:], cfg.budget - 1,
                                log, **STAGE_OPTIONS)
    if result is None:
        raise InputError(f"the earlier recommendation of {cfg.warm_start} flew unsafe now: the vehicle changed too "
                         "much for a warm start; start a new campaign (baseline restored)")
    return prior, result, unused


def say_condition(earlier: Earlier, again: Any, log: Callable[[str], None]) -> None:
    """One line: the earlier recommendation re-flown now against its earlier confirmation."""
    if earlier.confirm_rms is not None and again.rms is not None:
        change = again.rms / earlier.confirm_rms - 1.0
        what = (f"the earlier recommendation flies lap RMS {again.rms:.3f} m now, {earlier.confirm_rms:.3f} m in "
                f"its confirmation ({change:+.0%})")
        changed = abs(change) > CHANGED
    elif earlier.confirm_P is not None:
        what = f"the earlier recommendation scores P {again.P:+.3f} now, {earlier.confirm_P:+.3f} in its confirmation"
        changed = abs(again.P - earlier.confirm_P) > CHANGED
    else:
        log("warm start: the earlier campaign has no confirmation flight to compare with")
        return
    log(f"warm start: {what}: " + ("the vehicle or its conditions changed; the earlier flights stay the prior, "
                                   "this campaign's flights correct them" if changed else "nothing changed"))
