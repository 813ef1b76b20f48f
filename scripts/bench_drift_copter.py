"""A copter whose response degrades through the campaign: the JSBSim copter (``--vehicle copter3d``, ArduPilot
names) with its drag rising by RISE per minute of flight, so that the baseline's lap-2 RMS doubles over a
campaign of ``--budget 30`` (about 45 flights of ~50 s).

Three campaigns (our simulator in its own process, loopback UDP, lockstep), each followed by re-flights on the
same hovering vehicle, baseline and recommendation alternating (B R B R B R: the same condition on average):

- ``static``: no drift; what a campaign gains (baseline RMS - recommendation RMS, re-flown).
- ``stop``: drag rising, default ``--on-drift stop``: the flight where the drift became detectable (the baseline's
  true RMS 25 % over its first, the test's floor) and the flight where the campaign stopped.
- ``continue``: drag rising, ``--on-drift continue``: the recommendation against the baseline, both re-flown in
  the final condition, as a share of the static campaign's gain.

For every trial the optimiser was told was unsafe (P < 0, the corrected P where there is one), its gains and the
baseline are flown in process at that trial's drag: a trial counted unsafe whose gains beat the baseline in the
same condition is counted as "unsafe for drift". A trial's drag comes from its vehicle time (``time_boot_ms`` in
its tlog: the lockstep clock advances only while flying).

    PYTHONPATH=.dev-path python scripts/bench_drift_copter.py [--budget 30] [--rise 0.03] [--runs ...]
"""

from __future__ import annotations

import argparse
import io
import json
import statistics
import sys
import tempfile
import time
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

from pymavlink import mavutil

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

from _bench_common import machine, refly_in_turn, sim_and_endpoint  # noqa: E402

from ksbo_mav.cli import main  # noqa: E402
from ksbo_mav.mav.params import load_snapshot  # noqa: E402
from ksbo_sim.copter3d import Copter3D, fly  # noqa: E402
from ksbo_task.figure8_ne import Figure8H  # noqa: E402

SIM = ["--vehicle", "copter3d", "--personality", "ardupilot"]
TAKEOFF_S = 10.0  # flight time before trial 0's first sample (the climb to the mission's start)
FLOOR = 1.25  # the drift test's floor: RMS 25 % over the first flight


def lap2_rms(values: dict[str, float], drag: float) -> float:
    """Lap-2 RMS of the horizontal figure-8 flown in process at ``values`` with the drag times ``drag``."""
    v = Copter3D("ardupilot")
    for k, x in values.items():
        v.set_param(k, x)
    v.set_drag_scale(drag)
    return fly(v, Figure8H()).rms_lap2


def vehicle_times(tlog: Path) -> tuple[float, float]:
    """First and last LOCAL_POSITION_NED time_boot_ms of a trial tlog, in s."""
    m = mavutil.mavlink_connection(str(tlog))
    ts = []
    while (x := m.recv_match(type="LOCAL_POSITION_NED")) is not None:
        ts.append(x.time_boot_ms / 1000.0)
    return (ts[0], ts[-1]) if ts else (float("nan"), float("nan"))


def campaign(name: str, budget: int, rise: float, seed: int) -> dict:
    d = Path(tempfile.mkdtemp(prefix=f"drift-copter-{name}-")) / "camp"
    sim = [*SIM, "--seed", str(seed)] + (["--drag", f"1,{rise}"] if name != "static" else [])
    tune = ["--on-drift", "continue"] if name == "continue" else []
    err, out = io.StringIO(), io.StringIO()
    t = time.time()
    with sim_and_endpoint(*sim) as (_sim, ep):
        with redirect_stderr(err), redirect_stdout(out):
            rc = main(["tune", str(d), "--udp", f"127.0.0.1:{ep.port}", "--budget", str(budget), "--seed",
                       str(seed), "--end", "hold", "--json", *tune])
        wall = time.time() - t
        res = json.loads((d / "result.json").read_text()) if (d / "result.json").exists() else None
        flown = refly_in_turn(d, ep, {"recommendation": res["best"]["values"]}) if rc == 0 and res else None
        reflown = (flown["baseline"], flown["recommendation"]) if flown else None
    entries = [json.loads(x) for x in (d / "journal.jsonl").read_text().splitlines() if x.strip()]
    base_values = load_snapshot(d).baseline()
    t_first = vehicle_times(Path(entries[0]["record"]).with_suffix(".tlog"))[0] - TAKEOFF_S
    rows = []
    for e in entries:
        t0, t1 = vehicle_times(Path(e["record"]).with_suffix(".tlog"))
        drag = 1.0 + rise * ((t0 + t1) / 2 - t_first) / 60.0 if name != "static" else 1.0
        told = (e.get("cond") or {}).get("P_corrected", e["P"])
        rows.append({"trial": e["trial"], "kind": e["kind"], "P": e["P"], "P_told": told, "rms": e.get("rms"),
                     "drag": drag, "x": e["x"]})
    names = list(base_values)
    base_rms1 = lap2_rms(base_values, 1.0)
    detectable = next((r["trial"] for r in rows if lap2_rms(base_values, r["drag"]) >= FLOOR * base_rms1), None) \
        if name != "static" else None
    unsafe = [r for r in rows if r["kind"] == "opt" and r["P_told"] < 0]
    for r in unsafe:
        r["rms_same"] = lap2_rms(dict(zip(names, r["x"])), r["drag"])
        r["base_same"] = lap2_rms(base_values, r["drag"])
    text = " ".join(err.getvalue().split())
    drift = text[text.index("drift: "):].split(": check the vehicle")[0].split("; continuing")[0] \
        if "drift: " in text else None
    return {"run": name, "budget": budget, "rise_per_min": rise if name != "static" else 0.0, "seed": seed,
            "rc": rc, "wall_s": round(wall, 1), "flights": len(entries),
            "opt": sum(r["kind"] == "opt" for r in rows),
            "baseline_reflights": sum(r["kind"] == "baseline" for r in rows),
            "baseline_rms": [round(r["rms"], 3) for r in rows if r["kind"] in ("baseline",) or r["trial"] == 0],
            "final_drag": round(rows[-1]["drag"], 3), "detectable_trial": detectable,
            "stopped_trial": rows[-1]["trial"] if rc == 3 else None, "drift": drift,
            "unsafe_told": len(unsafe), "unsafe_for_drift": sum(r["rms_same"] < r["base_same"] for r in unsafe),
            "reflown_baseline": reflown[0] if reflown else None, "reflown_best": reflown[1] if reflown else None}


def cut(r: dict) -> float | None:
    if not r.get("reflown_baseline"):
        return None
    b, x = statistics.mean(r["reflown_baseline"]), statistics.mean(r["reflown_best"])
    return 1.0 - x / b


def main_() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget", type=int, default=30)
    ap.add_argument("--rise", type=float, default=0.03)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--runs", nargs="+", default=["static", "stop", "continue"])
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "drift" / "copter-runs.jsonl"))
    a = ap.parse_args()
    for name in a.runs:
        r = campaign(name, a.budget, a.rise, a.seed)
        r["cut"] = cut(r)
        r["machine"] = machine()
        print(json.dumps(r), flush=True)
        with open(a.out, "a") as fh:
            fh.write(json.dumps(r) + "\n")


if __name__ == "__main__":
    main_()
