"""Benchmark: the wind the report infers against the wind ArduCopter SITL blows, at 3, 5 and 8 m/s.

ArduCopter without drag fusion streams WIND 0 whatever blows; the report then infers the wind from each trial's own
telemetry (the lean angle against the ground velocity under a drag model: ksbo_mav.flightlog.wind_fit). For each set
wind (from 45 degrees, no gusts) a fresh SITL (-s 10) flies a short campaign (``ksbo-mav tune --budget 3 --confirm 1
--prior none --method random --validation off``); every completed trial's inferred wind is read from the journal and
compared with what the SITL blows at the mission's height, from its own parameters
(ksbo_mav.mav.wind_source.simulated_wind): ``SIM_WIND_T`` 1 blows the set speed at every height; 0, SITL's default,
shapes it by sqrt(h / 60 m), 41 % of the set speed at the mission's 10 m.

    python scripts/bench_wind_inference.py [--cases flat-3,flat-5,...] [--write]

Run it through /work/bin/heavy. Records: benchmarks/wind-inference/runs.jsonl; table: results.md (``--write``).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench_common import BENCH, machine, write_result  # noqa: E402

OUT = BENCH / "wind-inference"
CASES = {f"{shape}-{speed}": {"SIM_WIND_SPD": float(speed), "SIM_WIND_DIR": 45.0, "SIM_WIND_TURB": 0.0,
                              "SIM_WIND_T": 1.0 if shape == "flat" else 0.0}
         for shape in ("flat", "sqrt") for speed in (3, 5, 8)}


def run_case(name: str, tmp: Path) -> dict:
    from ksbo_mav.mav.params import load_snapshot
    from ksbo_mav.mav.wind_source import simulated_wind
    from ksbo_sim.sitl_instances import release_stopped, start_claimed

    sitl = start_claimed("ardupilot", 10)
    d = tmp / name
    try:
        for param, value in CASES[name].items():
            sitl.set_param(param, value)
        r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), *sitl.cli_args, "--budget", "3",
                            "--confirm", "1", "--prior", "none", "--method", "random", "--validation", "off"],
                           capture_output=True, text=True, timeout=1200)
    finally:
        sitl.stop()
        release_stopped()
    journal = [json.loads(x) for x in (d / "journal.jsonl").read_text().splitlines() if x.strip()] \
        if (d / "journal.jsonl").exists() else []
    snap = {n: v for n, (v, _) in load_snapshot(d.joinpath("snapshot", "vehicle.json")).params.items()} \
        if (d / "snapshot").exists() else {}
    height = json.loads((d / "campaign.json").read_text())["mission"]["center_up"] if journal else 10.0
    blows = simulated_wind(snap, height) if snap else None
    trials = [{"trial": e["trial"], "outcome": e["outcome"], "speed": e["cond"].get("wind_inferred_mps"),
               "from_deg": e["cond"].get("wind_inferred_from_deg"), "how": e["cond"].get("wind_inferred_how")}
              for e in journal if e.get("cond")]
    return {"case": name, "set": CASES[name], "height_m": height, "exit": r.returncode,
            "blows_mps": None if blows is None else round(blows[0], 3),
            "blows_from_deg": None if blows is None else blows[1], "trials": trials, "stderr_tail": r.stderr[-600:]}


def row(r: dict) -> str:
    ok = [t for t in r["trials"] if t["outcome"] == "ok" and t["speed"] is not None]
    speeds = [t["speed"] for t in ok]
    dirs = [t["from_deg"] for t in ok if t["from_deg"] is not None]
    s = r["set"]
    shape = "1 (flat)" if s["SIM_WIND_T"] == 1 else "0 (sqrt, SITL default)"
    if not speeds:
        return f"| {s['SIM_WIND_SPD']:g} | {shape} | {r['blows_mps']} | none inferred (exit {r['exit']}) | – | – |"
    med = statistics.median(speeds)
    err = (med - r["blows_mps"]) / r["blows_mps"] if r["blows_mps"] else float("nan")
    return (f"| {s['SIM_WIND_SPD']:g} from {s['SIM_WIND_DIR']:g}° | {shape} | {r['blows_mps']:.2f} | "
            f"{min(speeds):.2f}–{max(speeds):.2f} (median {med:.2f}, {len(speeds)} trials) | {err:+.0%} | "
            f"{min(dirs):.0f}–{max(dirs):.0f}° |")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", default=",".join(CASES), help="comma-separated (default: all: %(default)s)")
    ap.add_argument("--write", action="store_true", help="write results.md from every recorded case")
    a = ap.parse_args()
    todo = [c for c in a.cases.split(",") if c]
    if any(c not in CASES for c in todo):
        ap.error(f"known cases: {', '.join(CASES)}")
    OUT.mkdir(parents=True, exist_ok=True)
    runs = OUT / "runs.jsonl"
    for name in todo:
        with tempfile.TemporaryDirectory(prefix="ksbo-wind-") as tmp:
            t = time.time()
            rec = run_case(name, Path(tmp))
            rec["wall_s"], rec["machine"] = round(time.time() - t), machine()
        with open(runs, "a") as fh:
            fh.write(json.dumps(rec) + "\n")
        print(row(rec), flush=True)
    if a.write:
        latest = {r["case"]: r for r in (json.loads(x) for x in runs.read_text().splitlines() if x.strip())}
        recs = [latest[c] for c in CASES if c in latest]
        body = ("# Inferred wind against the wind ArduCopter SITL blows\n\n"
                f"Command: `python scripts/bench_wind_inference.py --write` (through /work/bin/heavy). Machine: "
                f"{recs[-1]['machine'] if recs else machine()}.\n\n" + __doc__.split("\n\n")[1].replace("\n", " ")
                + "\n\n| set (SIM_WIND_SPD) | SIM_WIND_T | blows at 10 m (m/s) | inferred per completed trial (m/s) | "
                  "median vs blows | inferred from |\n|---|---|---|---|---|---|\n" + "\n".join(row(r) for r in recs))
        write_result("wind-inference", body)
    return 0


if __name__ == "__main__":
    sys.exit(main())
