"""Cell kind ``fault``: one case of the fault matrix on ArduCopter SITL with the onboard guard.

A fresh SITL (``speedup``, default 10; Lua scripting on), the tuner (``ksbo-mav tune``, a short campaign: a budget
of 2 — the baseline and one optimiser trial — and one confirmation, random search, no prior) behind the link
emulator, a second MAVLink connection the tuner does not use (ksbo_sim.vehicle_watch: what the vehicle does) and,
with ``pilot``, the bench pilot (``ksbo-mav sim-pilot``) holding the sticks. The validation phases fly ``ksbo-mav
validate`` (small manoeuvres, twice with each gain set) on a finished campaign whose recommendation the case moved
off the baseline. At the ``phase``'s moment (ksbo_bench.kinds.fault_moments) the ``fault`` strikes: ``cut`` the
link for :data:`~ksbo_bench.kinds.fault_moments.CUT_S` of wall time and give it back, or ``kill`` the tuner (SIGKILL).

Recorded (``result``): the gains and mode at the fault; what the vehicle did after it (mode, arming, the guard and
its texts, in vehicle time); how long trial gains stayed on the vehicle after it; the gains, mode and arming left
at the end of the window (before any command); the tuner's exit status and last words; what continued it (after a
kill, ``restore`` and the command it names; after a cut the tuner goes on by itself, or the command its stop
printed), each with its exit status; and every parameter and the stored mission against the campaign's snapshot
once the bench landed the vehicle. ``flights`` and ``safety`` count the campaign's journal as the campaign kind does.

Key: ``fault`` (cut, kill), ``phase`` (:data:`~ksbo_bench.kinds.fault_moments.PHASES`), ``pilot`` (true, false);
``speedup``, ``seed``.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path
from typing import Any

from ksbo_bench.cell_errors import InfraError, SweepError
from ksbo_bench.kinds.fault_moments import FAULTS, PHASES


def check(key: dict[str, Any]) -> None:
    if key["fault"] not in FAULTS:
        raise SweepError(f"fault must be one of {', '.join(FAULTS)}, not {key['fault']!r}")
    if key["phase"] not in PHASES:
        raise SweepError(f"phase must be one of {', '.join(PHASES)}, not {key['phase']!r}")
    if not isinstance(key["pilot"], bool):
        raise SweepError("pilot is true or false")


def resources(key: dict[str, Any]) -> dict[str, float]:
    return {"sitl": 1}


def case_name(key: dict[str, Any]) -> str:
    return f"{key['fault']}-{key['phase']}-{'pilot' if key['pilot'] else 'alone'}"


def run(key: dict[str, Any], inputs: dict[str, Any] | None = None) -> dict[str, Any]:
    from ksbo_bench.kinds.campaign import GAIN_ABORTS
    from ksbo_bench.kinds.fault_case import fly_case
    from ksbo_sim.sitl_instances import release_stopped, start_claimed

    with tempfile.TemporaryDirectory(prefix="ksbo-fault-") as tmp:
        t0 = time.time()
        try:
            sitl = start_claimed("ardupilot", float(key.get("speedup", 10.0)), workdir=Path(tmp) / "sitl")
        except (RuntimeError, OSError, TimeoutError) as e:
            raise InfraError(f"ArduCopter SITL did not boot: {str(e)[:300]}") from e
        stoppers: list = []  # what the case started, stopped at its end however it ends
        try:
            try:
                rec = fly_case(key, sitl, Path(tmp), stoppers)
            finally:
                for stop_it in reversed(stoppers):
                    try:
                        stop_it()
                    except Exception as exc:  # noqa: BLE001 - the SITL must still be stopped
                        print(f"fault case clean-up: {exc}")
            rec.update(_end_state(sitl, Path(tmp) / "campaign"))
        finally:
            sitl.stop()
            release_stopped()
        wall = time.time() - t0
    journal = rec.pop("journal")
    safety = {"crashed": sum(e["outcome"] == "crash" for e in journal),
              "aborted": sum(e["outcome"] in GAIN_ABORTS for e in journal),
              "interrupted": sum(e["kind"] == "failed" for e in journal),
              "unsafe": sum(e["kind"] == "opt" and e.get("P") is not None and e["P"] < 0 for e in journal)}
    flights = {"total": len(journal) + rec["validation_flights"], "validation": rec.pop("validation_flights")}
    return {"status": "ok", "flights": flights, "safety": safety, "result": {"case": case_name(key), **rec},
            "timing": {"case_s": round(wall, 1), "load_1min": round(os.getloadavg()[0], 1)}}


def _end_state(sitl, d: Path) -> dict[str, Any]:
    """Every parameter against the campaign's snapshot, the stored mission's size and the arming, read afresh on
    the SITL's second port once the case is over."""
    from ksbo_mav.mav.link import Endpoint
    from ksbo_mav.mav.mission_transfer import MissionTransfer
    from ksbo_mav.mav.params import load_snapshot
    from ksbo_mav.mav.vehicle import Vehicle

    v = Vehicle.connect(Endpoint("tcp", "127.0.0.1", sitl.tcp_ports[1]), None, sysid=250, compid=190,
                        param_cache=False)
    try:
        hb = v.link.wait_heartbeat(5.0)
        now = {n: p.value for n, p in v.params.table.items()}
        items = len(MissionTransfer(v.link).download())
    finally:
        v.close()
    off = load_snapshot(d).off(now) if (d / "snapshot").exists() else None
    return {"params_vs_snapshot": None if off is None else {k: list(x) for k, x in off.items()},
            "mission_items_at_end": items, "armed_at_end": bool(hb.base_mode & 128)}
