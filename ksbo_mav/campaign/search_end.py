"""Why the search ended, in the pilot's units: the optimiser's stopping rule (:mod:`ksbo_mav.opt.methods.stopping`)
decides in units of the score P; on the 3-D copters P is linear in the lap RMS error
(``P = 1 - RMS / (ratio · RMS_ref)``, :meth:`ksbo_mav.mav.mission.Mission.score`), so a gain in P is a gain in metres
times ``ratio · RMS_ref``, read off the baseline flight (RMS / (1 − P)). Said on the console when the search stops
and kept in result.json and the report."""

from __future__ import annotations

from typing import Any

from ksbo_mav.campaign.journal import JournalEntry


def metres_per_P(baseline: JournalEntry | None) -> float | None:
    """Lap RMS (m) per unit of P from the baseline flight's own RMS and P; None without an RMS (the planar task)."""
    if baseline is None or not baseline.rms or baseline.P >= 1.0:
        return None
    return float(baseline.rms) / (1.0 - float(baseline.P))


def _amount(p: float, scale: float | None) -> str:
    return f"{p * scale:.3f} m" if scale is not None else f"{p:.4f} in P"


def search_end(stop: dict[str, Any] | None, baseline: JournalEntry | None, confirm: int) -> dict[str, Any] | None:
    """The stopping rule's record (``result.info["stop"]``) with the last check in metres and one sentence saying
    why the search ended; None when the rule was off. ``confirm``: the confirmation flights flown after it."""
    if not stop:
        return None
    scale = metres_per_P(baseline)
    out = dict(stop)
    last = stop["checks"][-1] if stop.get("checks") else None
    out["m_per_P"] = scale
    source = "measured" if stop.get("measured_noise") else "the model's"
    if stop.get("stopped") and last is not None:
        gain, noise = last["gain"], last["noise"]
        times = f" for {stop['patience']} trials in a row" if stop["patience"] > 1 else ""
        if stop.get("ratio", 1.0) != 1.0:
            times += f" (threshold {stop['ratio']:g} x the noise)"
        out["text"] = (f"search stopped after {stop['after']} of {stop['budget']} optimiser trials: the next flight "
                       f"is expected to gain {_amount(gain, scale)}; re-flight noise {_amount(noise, scale)} "
                       f"({source}){times}; {stop['saved']} flight(s) of the budget saved, "
                       f"then {confirm} confirmation flight(s)")
    else:
        gain = None if last is None else last["gain"]
        said = f"; the last check expected {_amount(gain, scale)}" if gain is not None else ""
        out["text"] = f"search used its whole budget of {stop['budget']} optimiser trials{said}"
    return out
