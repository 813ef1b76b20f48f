"""Cell kind ``flights``: fixed gain sets flown several ways on one fresh vehicle, in turn. No optimiser: the
training trial streamed from the ground (at the mission rate or another), flown on board, flown by a separate
client, and the validation manoeuvres (ksbo_bench.kinds.flight_ways), each set and way ``reps`` times, the order
of the sets and of the ways reversed every other repeat so that a slow change of the vehicle falls on all alike.

The vehicle is connected as ``ksbo-mav tune`` connects (the link check, which lowers the ground stream's mission
rate where the link cannot carry it; with an ``onboard`` way the onboard guard installed and rendered with the
figure-8), taken off, flown, landed.

Key: ``vehicle`` (ardupilot, px4; copter3d, our JSBSim copter in lockstep, for the streamed trial at the
mission's rate alone: it has no scripting, no second port, no validation modes of its own), ``ways`` (a list),
``gains`` (a table: set name -> the parameters it changes from the vehicle's defaults; the defaults are the set
"baseline"), ``reps`` (default 3), ``box`` ("profile", or "documented": the profile's box opened to the autopilot's
documented ranges and the trust region to all of it, for gains a campaign would not fly); ``tuned`` (a reference
to another sweep's recorded recommendation, as a
campaign's ``reference``: flown as the set "tuned"); the vehicle's own values (ksbo_bench.kinds.vehicles:
``speedup``, ``sitl_params``, ``link``, ``build``, ``personality``, ``sim_args``).

Figures: every flight's row (rep, set, way, outcome, lap-2 RMS, the stamp-true RMS, late setpoints, the
manoeuvre's metrics), the mission rate flown, the gains of each set.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from ksbo_bench.cell_errors import SweepError
from ksbo_bench.kinds import flight_ways
from ksbo_bench.kinds.work_folder import in_work_folder
from ksbo_bench.kinds.vehicles import SITL_KINDS, fresh_vehicle, is_sitl

PROFILE = {"ardupilot": "ardupilot-copter", "px4": "px4-copter"}


def _profile(key: dict[str, Any]) -> str:
    if key["vehicle"] == "copter3d":
        return PROFILE["px4" if key.get("personality") == "px4" else "ardupilot"]
    return PROFILE[key["vehicle"]]


def check(key: dict[str, Any]) -> None:
    if key["vehicle"] not in (*SITL_KINDS, "copter3d"):
        raise SweepError(f"flights: vehicle must be one of {', '.join(SITL_KINDS)}, copter3d, not {key['vehicle']!r}")
    if key["vehicle"] == "copter3d" and any(w != "streamed" for w in key["ways"]):
        # in lockstep every setpoint is one 20 ms simulator step: a mission at another rate waits for time that
        # never comes (measured: streamed@10 stopped for "no telemetry for 3.0 s")
        raise SweepError("flights: our JSBSim copter (lockstep) flies the streamed trial at its mission rate only")
    bad = [w for w in key["ways"] if not flight_ways.known(w)]
    if bad:
        raise SweepError(f"flights: unknown way {bad[0]!r} (streamed, streamed@HZ, onboard, "
                         f"{', '.join(flight_ways.CLIENTS)}, {', '.join(flight_ways.MANOEUVRES)})")
    if key.get("box", "profile") not in ("profile", "documented"):
        raise SweepError(f"flights: box must be profile or documented, not {key['box']!r}")
    if key["vehicle"] != "ardupilot" and any(w == "onboard" or w in flight_ways.CLIENTS for w in key["ways"]):
        raise SweepError("flights: the onboard trial and the separate client fly ArduCopter only")


def resources(key: dict[str, Any]) -> dict[str, float]:
    return {"sitl": 1} if is_sitl(key) else {}


def inputs(key: dict[str, Any]) -> dict[str, Any]:
    if "tuned" not in key:
        return {}
    from ksbo_bench.kinds.campaign import recorded

    return {"tuned": recorded(key, key["tuned"], "best_values")}


def run(key: dict[str, Any], inputs: dict[str, Any] | None = None) -> dict[str, Any]:
    return in_work_folder("flights", _run, key, inputs)


def _run(key: dict[str, Any], inp: dict[str, Any], work: Path) -> dict[str, Any]:
    from ksbo_mav.campaign.mission_rate import check_link
    from ksbo_mav.campaign.onboard import guard_link_timeout
    from ksbo_mav.errors import KsboError
    from ksbo_mav.mav.guard_script import config_for, figure8_for, new_config_id
    from ksbo_mav.mav.monitor import limits_from_profile
    from ksbo_mav.mav.onboard_guard import OnboardGuard
    from ksbo_mav.mav.vehicle import Vehicle

    said: list[str] = []

    def log(s: str) -> None:
        said.append(s)
        print(s, file=sys.stderr, flush=True)

    sets = {"baseline": {}, **dict(key.get("gains", {})), **({"tuned": inp["tuned"]} if "tuned" in inp else {})}
    rows: list[dict[str, Any]] = []
    with fresh_vehicle(key, work) as fresh:
        v = Vehicle.connect(fresh.ep, _profile(key), log=log)
        try:
            # key "box" = "documented" (the oracles): the profile's box, which is the autopilot's documented ranges
            # (a trial's gains are checked against it alone: trial_limits)
            check_link(v, log)
            base = {n: v.params.read(n) for n in v.gain_map.param_names}
            guard = None
            if "onboard" in key["ways"]:
                limits = limits_from_profile(v.profile)
                guard = OnboardGuard(v.link, v.params, v.cmd, log)
                guard.install(config_for(limits, guard_link_timeout(v, log), base, new_config_id(),
                                         figure8=figure8_for(v.mission, 1.5 * limits.tracking_error_max)))
                v.guard = guard
            v.ensure_airborne(log=log)
            if key["vehicle"] == "ardupilot" and any(w in flight_ways.MANOEUVRES for w in key["ways"]):
                flight_ways.centre_sticks(fresh.sitl.instance)
            ways = flight_ways.Ways(v, base, work, fresh.sitl, guard, log)
            rate = ways.rate
            xs = {name: v.gain_map.from_params({**base, **g}) for name, g in sets.items()}
            for rep in range(int(key.get("reps", 3))):
                order = list(xs) if rep % 2 == 0 else list(xs)[::-1]
                for name in order:
                    for way in (key["ways"] if rep % 2 == 0 else key["ways"][::-1]):
                        row = {"rep": rep, "set": name, "way": way, **ways.fly(way, name, xs[name])}
                        rows.append(row)
                        print(f"flights: {rep} {name} {way}: {row.get('outcome')} {row.get('true_rms')}",
                              file=sys.stderr, flush=True)
            v.guard = None
            if guard is not None:
                try:
                    guard.remove()
                except KsboError as exc:  # the flights are measured; a SITL thrown away keeps the script
                    log(f"onboard guard not removed: {exc}")
            v.land()
        finally:
            v.close()
    outcomes = [r.get("outcome") for r in rows]
    result = {"rate_hz": rate, "baseline": base, "sets": {k: {**base, **g} for k, g in sets.items()}, "flights": rows}
    if fresh.info.get("link"):
        result["link"] = fresh.info["link"]
    return {"flights": {"total": len(rows)},
            "safety": {"crashed": outcomes.count("crash"),
                       "aborted": sum(o in ("fence", "tilt", "track") for o in outcomes),
                       "interrupted": sum(o in ("stopped", "client failed") for o in outcomes), "unsafe": 0},
            "result": result}
