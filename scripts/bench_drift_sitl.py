"""ArduCopter SITL whose wind rises mid-campaign: calm until trial WIND_AT, then SIM_WIND_SPD (and SIM_WIND_TURB)
set through the SITL's second TCP port while the campaign flies. Then the campaign's recommendation and the
baseline are re-flown alternately (B R B R B R) on the same hovering vehicle, in the final wind.

Records whether the drift test fired and what it said, the flights, the trials counted unsafe, and the re-flown
lap-2 RMS of both. One JSON line per run, appended to benchmarks/drift/sitl-runs.jsonl.

    python scripts/bench_drift_sitl.py [--budget 30] [--wind-at 15] [--wind 6] [--turb 0]
        [--on-drift continue] [--seed 0] [--baseline-every N]

With ``--wind 0`` the SITL stays calm: a static campaign (with ``--baseline-every 0``, one without re-flights).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

from _bench_common import SPEED, campaign_vehicle, changed_params, machine  # noqa: E402

from ksbo_sim.sitl import start_sitl  # noqa: E402


def watch_journal(journal: Path, at: int, sitl, speed: float, turb: float, done: threading.Event,
                  log: dict) -> None:
    """Raise the wind once ``at`` trials are journalled (trial ``at`` flies in it), through the SITL's second TCP
    port (the campaign holds the first)."""
    while not done.is_set():
        if journal.exists() and len(journal.read_text().splitlines()) >= at:
            log["wind_set"] = [(n, sitl.set_param(n, v, second_port=True)) for n, v in
                               (("SIM_WIND_SPD", speed), ("SIM_WIND_TURB", turb))]
            log["wind_set_at_entries"] = len(journal.read_text().splitlines())
            return
        time.sleep(0.2)


def run(a: argparse.Namespace) -> dict:
    work = Path(tempfile.mkdtemp(prefix="bench-drift-sitl-"))
    sitl = start_sitl("ardupilot", instance=a.instance, speedup=SPEED["ardupilot"], workdir=work / "sitl")
    out: dict = {"budget": a.budget, "wind_at": a.wind_at, "wind_mps": a.wind, "turb": a.turb,
                 "on_drift": a.on_drift, "seed": a.seed, "baseline_every": a.baseline_every}
    try:
        d = work / "campaign"
        done = threading.Event()
        w = threading.Thread(target=watch_journal, args=(d / "journal.jsonl", a.wind_at, sitl, a.wind,
                                                          a.turb, done, out), daemon=True)
        w.start()
        t0 = time.time()
        r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), *sitl.cli_args, "--budget",
                            str(a.budget), "--seed", str(a.seed), "--on-drift", a.on_drift, "--end", "hold",
                            "--json", *(["--baseline-every", str(a.baseline_every)] if a.baseline_every is not None
                                        else [])], capture_output=True, text=True, timeout=7200)
        done.set()
        out.update(rc=r.returncode, wall_s=round(time.time() - t0, 1))
        text = " ".join(r.stderr.split())
        out["drift"] = text[text.index("drift: "):].split("; continuing")[0].split(": check")[0] \
            if "drift: " in text else None
        out["last_line"] = r.stderr.strip().splitlines()[-1] if r.stderr.strip() else ""
        entries = [json.loads(x) for x in (d / "journal.jsonl").read_text().splitlines() if x.strip()]
        out["flights"] = len(entries)
        out["kinds"] = {k: sum(e["kind"] == k for e in entries) for k in {e["kind"] for e in entries}}
        out["baseline_rms"] = [(e["trial"], round(e["rms"], 3)) for e in entries
                               if (e["kind"] == "baseline" or e["trial"] == 0) and e.get("rms")]
        out["unsafe_told"] = sum(e["kind"] == "opt" and (e.get("cond") or {}).get("P_corrected", e["P"]) < 0
                                 for e in entries)
        out["unsafe_flown"] = sum(e["kind"] == "opt" and e["P"] < 0 for e in entries)
        out["wind_seen"] = [(e["trial"], (e.get("cond") or {}).get("wind_mps")) for e in entries][::5]
        if r.returncode == 0:
            best = json.loads((d / "result.json").read_text())["best"]["values"]
            with campaign_vehicle(sitl, d, "refly") as (obj, x0):
                xb = obj.vehicle.gain_map.from_params(best)
                b, rr = [], []
                for _ in range(3):
                    b.append(obj.fly(x0, label="baseline").score["rms_lap2_m"])
                    rr.append(obj.fly(xb, label="recommendation").score["rms_lap2_m"])
            out.update(reflown_baseline=b, reflown_best=rr, best=best,
                       cut=1.0 - statistics.mean(rr) / statistics.mean(b))
            out["changed_params"] = changed_params(sitl, d)
    finally:
        sitl.stop()
    out["machine"] = machine()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget", type=int, default=30)
    ap.add_argument("--wind-at", type=int, default=15)
    ap.add_argument("--wind", type=float, default=6.0)
    ap.add_argument("--turb", type=float, default=0.0)
    ap.add_argument("--on-drift", default="continue")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--instance", type=int, default=5)
    ap.add_argument("--baseline-every", type=int, default=None, help="tune's --baseline-every (default: its own)")
    a = ap.parse_args()
    r = run(a)
    print(json.dumps(r), flush=True)
    with open(ROOT / "benchmarks" / "drift" / "sitl-runs.jsonl", "a") as fh:
        fh.write(json.dumps(r) + "\n")


if __name__ == "__main__":
    main()
