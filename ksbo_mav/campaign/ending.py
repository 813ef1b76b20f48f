"""The end of a campaign: the recommended gains flown again (confirmation flights), the vehicle left with the
baseline (or, accepted, the best) gains verified, then landed and disarmed or holding, and ``result.json`` written
once, atomically, with the report drawn beside it."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

import numpy as np

from ksbo_mav.campaign.access import write_accepted
from ksbo_mav.campaign.journal import JournalEntry
from ksbo_mav.campaign.layout import CampaignDir, write_file
from ksbo_mav.campaign.summary import CampaignSummary
from ksbo_mav.campaign.trials import TrialLoop
from ksbo_mav.errors import VehicleError
from ksbo_mav.mav.params import write_param_files
from ksbo_mav.mav.pilot import tool_modes
from ksbo_mav.mav.takeoff_landing import land
from ksbo_mav.mav.vehicle import Vehicle


def fly_confirmations(trials: TrialLoop, best: np.ndarray, n: int) -> list[float]:
    """P of ``n`` confirmation flights of ``best`` (d,): the journalled ones (a resume), then new ones."""
    confirms = [e.P for e in trials.journal.of("confirm")]
    for _ in range(len(confirms), n):
        confirms.append(trials.fly(best, "confirm").P)
    return confirms


def confirm_failures(confirms: list[JournalEntry]) -> list[str]:
    """Why the recommended gains should not be left on the vehicle: one line per confirmation flight that was
    aborted, crashed or scored P < 0 (empty: every confirmation flight completed safely, or there was none)."""
    return [f"confirmation trial {e.trial}: {e.outcome.text}" if e.outcome != "ok" else
            f"confirmation trial {e.trial}: P = {e.P:.3f} < 0" for e in confirms if e.outcome != "ok" or e.P < 0]


def leave_gains(v: Vehicle, d: CampaignDir, accept: bool, base: dict[str, float], best: dict[str, float],
                failures: list[str], log: Callable[[str], None]) -> bool:
    """At the end of a campaign: write the ``best`` parameters ({autopilot parameter name: value}) when ``accept``
    and no confirmation flight failed (``failures``: :func:`confirm_failures`), else
    the baseline ``base``; verified by a fresh read either way. Returns whether the best gains were accepted.
    Gains that failed a confirmation flight are never left on the vehicle by themselves."""
    accepted = accept and not failures
    if accepted:
        v.restore(best)  # write + fresh read-back of every gain
        write_accepted(d, base, best, v)
        log("accepted: best gains written and verified on the vehicle")
    else:
        v.restore(base)
        log("baseline gains restored and verified by a fresh read")
        if accept:
            log(f"--accept refused: {'; '.join(failures)} (`ksbo-mav accept {d.root} --force` writes them anyway)")
    return accepted


def export_recommended(d: CampaignDir, best: dict[str, float], v: Vehicle) -> None:
    """The recommendation as ``recommended.param`` / ``.params`` (Mission Planner, QGroundControl), written with the
    tune's first result, before any validation flight: what a stop afterwards must not lose."""
    types = {n: v.params.table[n].ptype for n in best}
    write_param_files(d.recommended_stem, best, types, v.identity.sysid, v.identity.compid)


def landed_by_itself(v: Vehicle, flight: Any) -> str | None:
    """Why a campaign whose trial lost its link found the vehicle on the ground once the link was back (the onboard
    guard's LOITER descends where nobody holds the throttle stick), else None."""
    if flight is None or flight.outcome != "link" or v.link.closed or v.guided.heartbeat is None or v.armed:
        return None
    return ("the vehicle landed and disarmed by itself while the link was down (the onboard guard's stop: "
            "ArduPilot's LOITER descends with the throttle stick low, nobody on the sticks)")


def safe_stop(v: Vehicle, base: dict[str, float], where: str, log: Callable[[str], None]) -> None:
    """After Ctrl-C or an error between trials: make sure the baseline is on the vehicle (verified)."""
    if v.link.closed:
        return
    try:
        v.restore(base)
        log("stopped: baseline gains restored and verified")
    except (VehicleError, KeyboardInterrupt) as exc:
        log(f"stopped: baseline NOT verified ({exc}); run `ksbo-mav restore {where}`")


def end_flight(v: Vehicle, end: str, error: bool, log: Callable[[str], None]) -> str:
    """Leave the vehicle landed and disarmed (``end`` "land", and after any stop below the mission altitude), or
    holding where it is (``end`` "hold"): confirmed by the heartbeat, or said why not. Returns what was done:
    "landed", "holding", "unknown" (could not tell), "pilot" (left alone: see below) or "" (it was not flying).

    A vehicle in a mode ksbo-mav never puts it in (ArduPilot LOITER or POSHOLD, PX4 Position: a pilot who took
    over; RTL or LAND: the autopilot's own action) is not the tool's to fly: it is neither landed nor held."""
    if v.link.closed or not v.armed:
        return ""
    g = v.guided
    hb = g.heartbeat
    if hb is not None and int(hb.custom_mode) not in tool_modes(v.stack):
        log(f"the vehicle is in {v.stack.mode_name(hb.custom_mode)}, a mode ksbo-mav did not set: left to the pilot "
            "(not landed, not held)")
        return "pilot"
    low = not g.height() >= 0.9 * float(v.mission.center_up)
    try:
        if end == "land" or (error and low):
            log("landing" + (" (stopped below the mission altitude)" if end != "land" else ""))
            land(g)
            log("landed and disarmed (confirmed by the heartbeat)")
            return "landed"
        here = g.position()
        if here is not None:
            g.hold_at(here)
        if v.stack.needs_stream:
            g.park()
        g.hold_at(None)
        log(f"holding at {g.height():.1f} m in {v.stack.mode_name(g.heartbeat.custom_mode)} (--end hold)")
        return "holding"
    except (VehicleError, KeyboardInterrupt) as exc:
        log(f"could not land/hold the vehicle: {exc}; it is now under its own failsafes - take over")
        return "unknown"


def rewrite_report(d: CampaignDir, profile: Any, log: Callable[[str], None], draw: bool = True) -> str | None:
    """The report written again from disk (after later flights, ``ksbo-mav validate``; after a stop, without
    ``draw``: the page only, quick); a report that cannot be made is said, never an error on top of the flights or
    the stop. Returns its page, if written."""
    if not d.exists():
        return None
    try:
        from ksbo_mav.campaign.report.writer import write_report

        page = write_report(d, profile, draw=draw).get("page")
        if page:
            log(f"report: {page}")
        return page
    except Exception as exc:  # noqa: BLE001 - the flights and their journal matter more than the page
        log(f"report not written: {exc}")
        return None


def write_result(d: CampaignDir, summary: CampaignSummary, profile: Any, log: Callable[[str], None]) -> None:
    """Draw the report plots into ``summary.plots`` (a plotting problem is logged, never hides the result), then
    write ``result.json`` (temporary file, fsync, rename)."""
    try:
        from ksbo_mav.campaign.report.writer import write_report

        summary.plots = write_report(d, profile, summary.to_dict())
    except Exception as exc:  # a plotting problem must never hide the tuning result
        log(f"report plots failed: {exc}")
    write_file(d.result, json.dumps(summary.to_dict(), indent=1))
