"""Analyses a campaign cell runs on its finished campaign folder before the folder goes (key ``analyses``, a list
of names): each adds its figures to the record's ``result``.

- ``drift``: the baseline's re-flights (how many, their lap RMS by trial), trials the optimiser was told were
  unsafe (P < 0, the corrected P where there is one) and flown unsafe, the wind the journal saw.
- ``drift-copter``: our JSBSim copter with its drag rising (``sim_args`` ``--drag 1,RISE``): each trial's drag
  from its vehicle time (the lockstep clock advances only while flying), the trial at which the drift became
  detectable (the baseline's true lap RMS, flown in process at that drag, 25 % over its first: the drift test's
  floor) and, of the trials told unsafe, those whose gains beat the baseline in the same condition (unsafe for
  the drift alone).
- ``planar``: the planar vehicle's recommendation and baseline re-flown in process over the 8 fixed initial
  conditions (``EP`` monitored, as the plant suite judges; ``reflown_P`` as `ksbo-mav evaluate --fixed` does).
- ``planar-twin``: the same optimiser, prior, bounds and seed run in process on the monitored planar simulator
  (random initial conditions): what the MAVLink campaign should match.
- ``validation``: the campaign's validation verdicts and what kept it in real time (ksbo_bench.kinds.
  campaign_validation).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Callable

import numpy as np

TAKEOFF_S = 10.0  # flight time before trial 0's first sample (the climb to the mission's start)
FLOOR = 1.25  # the drift test's floor: RMS 25 % over the first flight


def _entries(d: Path) -> list[dict]:
    return [json.loads(x) for x in (d / "journal.jsonl").read_text().splitlines() if x.strip()]


def _told(e: dict) -> float:
    return (e.get("cond") or {}).get("P_corrected", e["P"])


def drift(key: dict, d: Path, result: dict) -> None:
    entries = _entries(d)
    result["baseline_rms"] = [(e["trial"], round(e["rms"], 4)) for e in entries
                              if (e["kind"] == "baseline" or e["trial"] == 0) and e.get("rms")]
    result["baseline_P"] = [round(e["P"], 4) for e in entries if e["kind"] == "baseline"]
    result["unsafe_told"] = sum(e["kind"] == "opt" and _told(e) < 0 for e in entries)
    result["unsafe_flown"] = sum(e["kind"] == "opt" and e["P"] < 0 for e in entries)
    result["wind_seen"] = [(e["trial"], (e.get("cond") or {}).get("wind_mps")) for e in entries][::5]
    if result.get("rc") == 3 and entries:  # the campaign stopped (the drift test, by default): at which trial
        result["stopped_trial"] = entries[-1]["trial"]


def _vehicle_times(tlog: Path) -> tuple[float, float]:
    """First and last LOCAL_POSITION_NED time_boot_ms of a trial tlog, in s."""
    from pymavlink import mavutil

    m = mavutil.mavlink_connection(str(tlog))
    ts = []
    while (x := m.recv_match(type="LOCAL_POSITION_NED")) is not None:
        ts.append(x.time_boot_ms / 1000.0)
    return (ts[0], ts[-1]) if ts else (float("nan"), float("nan"))


def _lap2_rms(values: dict[str, float], drag: float, personality: str) -> float:
    from ksbo_sim.copter3d import Copter3D, fly
    from ksbo_task.figure8_ne import Figure8H

    v = Copter3D(personality)
    for k, x in values.items():
        v.set_param(k, x)
    v.set_drag_scale(drag)
    return fly(v, Figure8H()).rms_lap2


def _drag_rise(sim_args: list[str]) -> float:
    args = list(map(str, sim_args))
    if "--drag" in args:
        parts = args[args.index("--drag") + 1].split(",")
        return float(parts[1]) if len(parts) > 1 else 0.0
    return 0.0


def drift_copter(key: dict, d: Path, result: dict) -> None:
    from ksbo_mav.mav.params import load_snapshot

    rise, pers = _drag_rise(key.get("sim_args", [])), key.get("personality", "ardupilot")
    entries = _entries(d)
    base = load_snapshot(d).baseline()
    t_first = _vehicle_times(Path(entries[0]["record"]).with_suffix(".tlog"))[0] - TAKEOFF_S
    drags = []
    for e in entries:
        t0, t1 = _vehicle_times(Path(e["record"]).with_suffix(".tlog"))
        drags.append(1.0 + rise * ((t0 + t1) / 2 - t_first) / 60.0)
    result["final_drag"] = round(drags[-1], 3)
    if rise:
        first = _lap2_rms(base, 1.0, pers)
        result["detectable_trial"] = next((e["trial"] for e, g in zip(entries, drags)
                                           if _lap2_rms(base, g, pers) >= FLOOR * first), None)
    unsafe = [(e, g) for e, g in zip(entries, drags) if e["kind"] == "opt" and _told(e) < 0]
    result["unsafe_for_drift"] = sum(_lap2_rms(dict(zip(base, e["x"])), g, pers) < _lap2_rms(base, g, pers)
                                     for e, g in unsafe)


def planar(key: dict, d: Path, result: dict) -> None:
    from ksbo_mav.simulated.planar_objective import SimObjective

    res = json.loads((d / "result.json").read_text()) if (d / "result.json").exists() else None
    if not res:
        return
    judge, plain = SimObjective("sim-planar", monitor=True), SimObjective("sim-planar")
    best, base = np.array(res["best"]["x"]), np.array(res["baseline"]["x"])
    result["EP"], result["EP_baseline"] = (float(v) for v in judge.expected(np.stack([best, base])))
    result["reflown_P"] = float(plain.expected(best)[0])
    result["P_confirm"] = res["best"].get("P_confirm")


def planar_twin(key: dict, d: Path, result: dict) -> None:
    from ksbo_mav import optimize
    from ksbo_mav.campaign import optimizer_options
    from ksbo_mav.profiles import load_profile
    from ksbo_mav.simulated.planar_objective import SimObjective

    camp = json.loads((d / "campaign.json").read_text())
    prior = json.loads((d / "prior.json").read_text())
    cfg = camp["config"]
    ref = optimize(SimObjective("sim-planar", seed=key["seed"], monitor=True), np.array(camp["x0"]),
                   np.array(camp["bounds"]), budget=cfg["budget"], seed=key["seed"],
                   prior=(np.array(prior["X"]), np.array(prior["y"])), method=cfg["method"],
                   **optimizer_options(prior["kind"], cfg.get("options", {}), cfg["method"],
                                       load_profile("sim-planar")))
    result["twin"] = {"EP": float(SimObjective("sim-planar", monitor=True).expected(ref.x)[0]),
                      "unsafe": int(ref.n_unsafe), "aborted": int(ref.n_aborted), "crashed": int(ref.n_crashed)}


def validation(key: dict, d: Path, result: dict) -> None:
    from ksbo_bench.kinds.campaign_validation import figures

    result.update(figures(d))


ANALYSES: dict[str, Callable[[dict, Path, dict], None]] = {
    "drift": drift, "drift-copter": drift_copter, "planar": planar, "planar-twin": planar_twin,
    "validation": validation,
}


def run(key: dict[str, Any], d: Path, result: dict[str, Any]) -> None:
    for name in key.get("analyses", []):
        ANALYSES[name](key, d, result)
