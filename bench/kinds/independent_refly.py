"""The independent re-fly: on the vehicle a campaign left hovering, named gain sets flown in turn (B R L B R L ...,
so each sees the same condition on average) through the tuner's own objective, by flights separate from the
campaign; and the parameters the campaign left changed. A re-flight the tuner stopped for its own sake (it fell
behind the vehicle on a loaded machine, the link) is flown again; one the monitor aborted is a result (no RMS)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any


def _fly(obj, x, label: str, tries: int = 3) -> dict:
    """The re-flight's score (empty when the tuner stopped it ``tries`` times)."""
    from ksbo_mav.errors import TrialStopped

    for k in range(tries):
        try:
            return obj.fly(x, label=label).score
        except TrialStopped as e:
            print(f"re-flight of {label} stopped ({e}); flying it again", file=sys.stderr)
            if k == tries - 1:
                raise
    return {}


#: What a re-flight's score says about smoothness (ksbo_mav.smoothness), by the name its figures go under.
SMOOTHNESS = {"rough": "rough_dps", "motor": "motor_osc_us"}


def stream_motor_outputs(v) -> None:
    """Ask vehicle ``v`` for SERVO_OUTPUT_RAW at its mission's rate (the motor oscillation is measured from it;
    the tuner only records it where the vehicle streams it of its own accord): a direct link to a SITL has room."""
    from ksbo_mav.mav.wire import mavlink

    v.cmd.set_interval(mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, 1e6 / v.mission.rate_hz)


def refly_in_turn(d: Path, ep, gains: dict[str, dict[str, float]], n: int = 3,
                  smooth: dict[str, dict[str, list[float | None]]] | None = None) -> dict[str, list[float | None]]:
    """{"baseline" and each label of ``gains`` ({label: {parameter: value}}): lap-2 RMS of each of its ``n``
    flights}, flown in turn on the vehicle the campaign in ``d`` left hovering (reached at Endpoint ``ep``); lands.
    Gains not named in a set keep the baseline's values. ``smooth``, when given, receives each flight's roughness
    (deg/s) and motor oscillation (µs) the same way, under the names of :data:`SMOOTHNESS`."""
    from ksbo_mav.mav.objective import MavlinkObjective
    from ksbo_mav.mav.params import load_snapshot
    from ksbo_mav.mav.vehicle import Vehicle

    snap = load_snapshot(d)
    v = Vehicle.connect(ep, snap.profile)
    try:
        v.setup_streams()
        stream_motor_outputs(v)
        base = snap.baseline()
        safety = _as_flown(v, d)
        obj = MavlinkObjective(v, base, Path(d) / "refly", first_index=0, safety=safety)
        xs = {"baseline": v.gain_map.from_params(base),
              **{k: v.gain_map.from_params({**base, **g}) for k, g in gains.items()}}
        out: dict[str, list[float | None]] = {k: [] for k in xs}
        for _ in range(n):
            for k, x in xs.items():
                score = _fly(obj, x, k)
                out[k].append(score.get("rms_lap2_m"))
                for name, field in SMOOTHNESS.items() if smooth is not None else ():
                    smooth.setdefault(name, {}).setdefault(k, []).append(score.get(field))
        v.land()
        return out
    finally:
        v.close()


def _as_flown(v, d: Path) -> dict[str, float]:
    """The campaign's own settings on ``v``: the figure-8 it flew (a wind plan may have scaled it) and its safety
    limits (a wind plan may have raised the tilt limit); returns the limits. Re-flown otherwise, a set the campaign
    flew inside its limits could be aborted by the profile's."""
    from dataclasses import replace

    from ksbo_mav.campaign.layout import CampaignDir

    settings = CampaignDir.at(d).read_settings()
    flown = settings.get("mission") or {}
    if flown.get("kind") == v.mission.kind and "scale" in flown:
        v.mission = replace(v.mission, scale=float(flown["scale"]), scale2=float(flown["scale2"]))
    return dict(settings["config"].get("safety") or {})


def changed_params(ep, stack: str, d: Path) -> list[str]:
    """The vehicle's parameters (read at Endpoint ``ep``, a direct link) that differ from the snapshot of the
    campaign in ``d``, those the ``stack`` autopilot updates itself aside."""
    from ksbo_mav.mav.params import load_snapshot
    from ksbo_mav.mav.vehicle import Vehicle

    snap = load_snapshot(d)
    v = Vehicle.connect(ep, snap.profile, sysid=250, compid=190)
    try:
        now = {k: p.value for k, p in v.params.table.items()}
    finally:
        v.close()
    return sorted(snap.off(now))


def mean(xs: list[Any]) -> float | None:
    v = [x for x in xs if x is not None]
    return sum(v) / len(v) if v else None
