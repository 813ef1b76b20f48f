"""A waypoint mission flown by the autopilot's own navigation (ArduPilot AUTO, PX4 Mission) at its own speeds.

The user's stored mission is downloaded first (kept on disk too, where the vehicle's ``mission_file`` says: a campaign's
``ksbo-mav restore`` puts it back after a tuner killed mid-flight) and put back afterwards (or the mission cleared when
there was none), whatever the outcome, once the vehicle is back in guided/offboard or left to the pilot. The mission's
waypoints go up with the mission protocol (:mod:`ksbo_mav.mav.mission_transfer`), the vehicle switches to its auto
mode and flies them; the flight ends when the vehicle reports the last item reached (MISSION_ITEM_REACHED) or is
within ``arrive_m`` of it, plus ``settle_s`` to see it stop. PX4 switches to Hold (AUTO.LOITER) by itself once its
mission is finished: from the last item's report on, that mode is no take-over. PX4's waypoints carry their own
acceptance radius (:func:`px4_accept_m`): PX4 main no longer sets a multicopter's ``NAV_ACC_RAD`` to 2 m, and its
10 m default is wider than the legs, so every item counted as reached the moment the mission started (measured:
"Mission finished, loitering" 48 ms after "Executing Mission"). Cross-track, corner and completion figures are
:func:`ksbo_task.manoeuvre_metrics.mission_tracking` of the position samples against the straight legs.
"""

from __future__ import annotations

import numpy as np

from ksbo_mav.errors import VehicleError
from ksbo_mav.mav.mission_transfer import MissionTransfer, load_items, save_items
from ksbo_mav.mav.validation.manoeuvre_frame import ManoeuvreFrame
from ksbo_mav.mav.validation.manoeuvre_recorder import cfg_text, end_text, go_text, start_text, wp_text
from ksbo_mav.mav.validation.manoeuvre_spec import ManoeuvreSpec


#: PX4's multicopter acceptance radius up to 1.16 (rc.mc_defaults ``NAV_ACC_RAD 2``), sent with each waypoint.
PX4_ACCEPT_M = 2.0


def px4_accept_m(wps: np.ndarray) -> float:
    """The acceptance radius PX4's waypoints carry: :data:`PX4_ACCEPT_M`, or a quarter of the shortest leg when
    that is smaller (most of every leg flown: the corner figures measure the position loop, not the switch)."""
    legs = np.linalg.norm(np.diff(np.asarray(wps, float), axis=0), axis=1)
    return float(min(PX4_ACCEPT_M, legs[legs > 0].min() / 4.0))


def fly_auto_mission(frame: ManoeuvreFrame, spec: ManoeuvreSpec, start: np.ndarray, label: str, detail: dict) -> None:
    """Upload, fly and measure the mission from ``start``; what it flew goes into ``detail``."""
    v = frame.v
    frame.hold_target(start, spec.settle_s)
    transfer = MissionTransfer(v.link)
    saved = transfer.download()
    kept = v.mission_file  # the user's mission on disk while ours replaces it: a tuner killed mid-flight loses nothing
    if kept is not None and kept.is_file():  # an earlier flight stopped before putting it back: that one is the user's
        saved = load_items(kept)
    elif kept is not None:
        save_items(kept, saved)
    detail.update(start_ned=[float(x) for x in start], user_mission_items=len(saved))

    def put_back() -> None:
        transfer.upload(saved)  # an empty mission is cleared
        detail["user_mission_restored"] = True
        if kept is not None:
            kept.unlink(missing_ok=True)

    detail["user_mission_restored"] = False
    frame.after.append(put_back)
    wps = spec.waypoints(start)
    geo = transfer.global_frame()
    px4 = v.stack.name == "px4"
    items = [] if px4 else [geo.home_item()]  # ArduPilot numbering: item 0 is home
    accept = px4_accept_m(wps) if px4 else 0.0  # ArduPilot: its own WPNAV_RADIUS, as verified
    items += [geo.waypoint(p, yaw=float("nan") if px4 else 0.0, accept_m=accept) for p in wps[1:]]
    detail["accept_m"] = accept
    transfer.upload(items)
    first = 0 if px4 else 1
    last = len(items) - 1
    transfer.set_current(first)
    frame.marker(start_text(spec.kind, frame.now_ms(), label))
    frame.started = True
    frame.marker(cfg_text(spec.settle_fraction, spec.settle_floor_m, spec.settle_band_m, spec.arrive_m))
    for p in wps:
        frame.marker(wp_text(p))
    detail["waypoints_ned"] = [[float(x) for x in p] for p in wps]
    reached: set[int] = set()
    current = [first]

    def on_msg(msg) -> None:
        if msg.get_type() == "MISSION_ITEM_REACHED" and v.link.is_vehicle(msg):
            reached.add(int(msg.seq))
        elif msg.get_type() == "MISSION_CURRENT" and v.link.is_vehicle(msg):
            current[0] = int(msg.seq)

    v.link.handlers.append(on_msg)
    try:
        t_go = frame.enter("auto")
        frame.marker(go_text(t_go))

        def arrived() -> bool:  # (a box ends where it started: near the last point counts on the last leg only)
            here = v.guided.position()
            return last in reached or (current[0] == last and here is not None
                                       and float(np.linalg.norm(here - wps[-1])) <= spec.arrive_m)

        def finished_modes() -> set[int]:
            return {v.stack.modes["hold"]} if last in reached else set()

        if not frame.watch(spec.timeout_s, "auto", arrived, finished_modes):
            raise VehicleError(f"the mission did not complete within {spec.timeout_s:g} s of vehicle time")
        frame.watch(spec.settle_s, "auto", also=finished_modes)
    finally:
        v.link.handlers.remove(on_msg)
    frame.marker(end_text(frame.now_ms(), "ok"))
    frame.ended = True
    detail["items_reached"] = sorted(reached)
    frame.back_to_guided()
    frame.hold_target(start, spec.settle_s)
