"""The result of a finished campaign: the summary counted from the journal, the report plots, and ``result.json``,
written once, atomically, at the very end."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

import numpy as np

from ksbo_mav.campaign.journal import Journal, JournalEntry
from ksbo_mav.campaign.layout import CampaignDir
from ksbo_mav.campaign.summary import CampaignSummary
from ksbo_mav.mav.params.snapshot import fsync_write


def summarize(journal: Journal, result: Any, *, baseline_x: np.ndarray, base: dict[str, float], baseline_trial: int,
              best_params: dict[str, float], confirms: list[float], failures: list[str], unused: list[JournalEntry],
              accepted: bool, accept: bool, on_vehicle: dict[str, float], method: str, wall_s: float,
              d: CampaignDir, ended: str) -> CampaignSummary:
    """What the campaign did, safety counted three ways from the ``journal``.

    Args:
        result: the optimiser's result (``x`` (d,) the recommendation, ``fun`` its model mean, ``orders``).
        baseline_x, base: the baseline gain vector (d,) and its {autopilot parameter name: value}.
        best_params: the recommendation as {autopilot parameter name: value}.
        confirms, failures: P of the confirmation flights, and why any of them failed.
        unused: journalled trials a diverged replay could not use.
        accepted, accept: the best gains were left on the vehicle; --accept asked for that.
        on_vehicle: the tuned parameters on the vehicle now; ended: how the vehicle was left.
    """
    opt = journal.of("opt")
    gain_aborts = [e for e in journal.entries if e.outcome.gain_caused]
    return CampaignSummary(
        baseline={"x": baseline_x.tolist(), "values": base, "P": opt[0].P if opt else None,
                  "trial": baseline_trial, "rms_m": opt[0].rms if opt else None},
        best={"x": np.asarray(result.x, dtype=float).tolist(), "values": best_params, "P_model": float(result.fun),
              "P_confirm": float(np.mean(confirms)) if confirms else None, "P_confirm_all": confirms,
              "confirm_failures": failures,
              "unused_journal_trials": [e.trial for e in unused]},
        accepted=accepted, accept_refused="; ".join(failures) if accept else "",
        on_vehicle=on_vehicle, n_trials=len(journal.entries),
        n_unsafe=int(sum(e.P < 0 for e in opt)),
        n_aborted=sum(e.outcome != "crash" for e in gain_aborts),
        n_crashed=sum(e.outcome == "crash" for e in gain_aborts), n_failed=len(journal.of("failed")),
        method=method, orders=list(result.orders) if result.orders else None, wall_s=wall_s,
        dir=str(d.root), ended=ended)


def write_result(d: CampaignDir, summary: CampaignSummary, profile: Any, log: Callable[[str], None]) -> None:
    """Draw the report plots into ``summary.plots`` (a plotting problem is logged, never hides the result), then
    write ``result.json`` (temporary file, fsync, rename)."""
    try:
        from ksbo_mav.campaign.report import write_report

        summary.plots = write_report(d, profile, summary.to_dict())
    except Exception as exc:  # a plotting problem must never hide the tuning result
        log(f"report plots failed: {exc}")
    fsync_write(d.result, json.dumps(summary.to_dict(), indent=1))
