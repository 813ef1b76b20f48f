"""Benchmark: tuning campaigns on real autopilot SITLs from the ground.

For each stack (ArduCopter SITL at -s 10, PX4 SITL at -s 5) and seed: start a fresh SITL, run
``ksbo-mav tune --budget N --confirm 3`` from the ground (takeoff, trials, landing), then re-fly the baseline gains
3 times on the same vehicle (the recommendation was re-flown 3 times by the campaign itself), land, and download
every parameter to count those left changed (outside the autopilot-updated list). Reports wall time per trial and
per campaign, baseline and recommendation lap-2 RMS (mean of 3 re-flights each), aborts and changed parameters.

    python scripts/bench_sitl_campaign.py [--seeds 0 1 2] [--budget 30] [--stacks ardupilot px4] [--no-write]
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
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

import numpy as np

os.environ.setdefault("MAVLINK20", "1")

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench_common import machine, write_result  # noqa: E402

from ksbo_mav.mav.link import Endpoint  # noqa: E402
from ksbo_mav.mav.objective import MavlinkObjective  # noqa: E402
from ksbo_mav.mav.params import load_snapshot  # noqa: E402
from ksbo_mav.mav.stacks import autopilot_updated  # noqa: E402
from ksbo_mav.mav.vehicle import Vehicle  # noqa: E402
from ksbo_sim.sitl import start_sitl  # noqa: E402

SPEED = {"ardupilot": 10.0, "px4": 5.0}


def endpoint(sitl, second: bool = False) -> tuple[list[str], Endpoint]:
    if sitl.kind == "ardupilot":
        port = sitl.tcp_ports[1] if second else sitl.tcp_port
        return ["--tcp", f"127.0.0.1:{port}"], Endpoint("tcp", "127.0.0.1", port)
    return ["--udp", f"127.0.0.1:{sitl.udp_port}"], Endpoint("udp", "127.0.0.1", sitl.udp_port)


@contextmanager
def campaign_vehicle(sitl, d: Path, out: str) -> Iterator[tuple[MavlinkObjective, np.ndarray]]:
    """The vehicle the campaign in ``d`` left hovering: the tuner's own objective (flights written to ``d / out``,
    restoring the snapshot's baseline) and the baseline gain vector x0 (d,). Lands when the block ends normally."""
    _, ep = endpoint(sitl)
    snap = load_snapshot(d)
    v = Vehicle.connect(ep, snap.profile)
    try:
        v.setup_streams()
        base = snap.baseline()
        yield MavlinkObjective(v, base, d / out, first_index=0), v.gain_map.from_params(base)
        v.land()
    finally:
        v.close()


def reflown_baseline(sitl, d: Path, n: int) -> list[float]:
    """Fly the baseline gains ``n`` times on the vehicle (hovering after the campaign), then land."""
    with campaign_vehicle(sitl, d, "baseline-reflights") as (obj, x0):
        return [obj.fly(x0, label="baseline").score["rms_lap2_m"] for _ in range(n)]


def changed_params(sitl, d: Path) -> list[str]:
    _, ep = endpoint(sitl)
    snap = load_snapshot(d)
    v = Vehicle.connect(ep, snap.profile, sysid=250, compid=190)
    try:
        now = {k: p.value for k, p in v.params.table.items()}
    finally:
        v.close()
    return sorted(k for k, (val, _) in snap.params.items()
                  if not autopilot_updated(sitl.kind, k)
                  and (k not in now or abs(now[k] - val) > 1e-6 * max(1.0, abs(val))))


def run_one(kind: str, seed: int, budget: int, instance: int, method: str = "ksbo",
            options: list[str] | None = None, n_prior: int = 0) -> dict:
    """One campaign; ``n_prior`` > 0 flies that many local-LHS prior trials first (`--prior local`), else
    `--prior none`."""
    work = Path(tempfile.mkdtemp(prefix=f"bench-sitl-{kind}-{seed}-"))
    sitl = start_sitl(kind, instance=instance, speedup=SPEED[kind], workdir=work / "sitl")
    try:
        if kind == "px4":
            sitl.set_param("COM_RCL_EXCEPT", 4, int32=True)  # no RC in SITL: allow OFFBOARD without it
        args, _ = endpoint(sitl)
        d = work / "campaign"
        prior = ["--prior", "local", "--n-prior", str(n_prior)] if n_prior else ["--prior", "none"]
        t0 = time.time()
        r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), *args, "--budget", str(budget),
                            "--seed", str(seed), "--method", method, *prior, "--confirm", "3",
                            "--end", "hold", "--json", *[f"--option={o}" for o in options or []]],
                           capture_output=True, text=True, timeout=3600)
        wall = time.time() - t0
        if r.returncode != 0:
            return {"kind": kind, "seed": seed, "error": r.stderr.strip().splitlines()[-1], "wall_s": wall}
        s = json.loads(r.stdout[r.stdout.index("{"):])
        recs = [json.loads(p.read_text()) for p in sorted((d / "trials").glob("trial_*.json"))]
        flown = [x["score"].get("rms_lap2_m") for x in recs if x["label"] == "confirm"]
        confirm = [v for v in flown if v is not None]  # a confirm flight the monitor aborted has no RMS
        base = reflown_baseline(sitl, d, 3)
        changed = changed_params(sitl, d)
        return {"kind": kind, "seed": seed, "method": method, "options": options or [], "n_prior": n_prior,
                "wall_s": wall,
                "trials": len(recs),
                "wall_per_trial_s": statistics.median(x["wall_s"] for x in recs),
                "baseline_rms": statistics.mean(base),
                "best_rms": statistics.mean(confirm) if confirm else float("nan"),
                "confirm_flown": len(flown), "confirm_aborted": len(flown) - len(confirm),
                "aborted": s["n_aborted"], "unsafe": s["n_unsafe"], "failed": s.get("n_failed", 0),
                "crashed": s.get("n_crashed", 0),
                "changed_params": changed}
    finally:
        sitl.stop()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--budget", type=int, default=30)
    ap.add_argument("--stacks", nargs="+", default=["ardupilot", "px4"], choices=sorted(SPEED))
    ap.add_argument("--method", default="ksbo", help="optimiser of the campaigns (default ksbo)")
    ap.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                    help="optimiser option passed to `ksbo-mav tune --option` (repeatable)")
    ap.add_argument("--no-write", action="store_true",
                    help="print only, do not write benchmarks/sitl-campaign/results.md")
    args = ap.parse_args()
    rows = []
    for kind in args.stacks:
        for k, seed in enumerate(args.seeds):
            row = run_one(kind, seed, args.budget, instance=5 + k, method=args.method, options=args.option)
            print(json.dumps(row), flush=True)
            rows.append(row)
    lines = [f"Machine: {machine()}. Script: `python scripts/bench_sitl_campaign.py --budget {args.budget} --seeds "
             f"{' '.join(map(str, args.seeds))} --method {args.method}"
             + "".join(f" --option {o}" for o in args.option) + "`. Each campaign starts on the ground with "
             "fresh parameters "
             f"(ArduCopter SITL -s {SPEED['ardupilot']:g}, PX4 SITL -s {SPEED['px4']:g}, COM_RCL_EXCEPT 4 set by "
             "the script), `--prior none`, the recommendation re-flown 3 times (`--confirm 3`), the baseline "
             "re-flown 3 times afterwards; RMS = lap-2 3-D RMS tracking error, mean of the 3 re-flights.", "",
             "| stack | seed | trials | wall/trial (s) | campaign wall (s) | baseline RMS (m) | recommended RMS (m) "
             "| change | aborted | unsafe | failed (not gains) | params left changed | re-flights aborted |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['kind']} | {r['seed']} | campaign failed: {r['error']} |")
            continue
        change = 100.0 * (r["best_rms"] / r["baseline_rms"] - 1.0)
        lines.append(f"| {r['kind']} | {r['seed']} | {r['trials']} | {r['wall_per_trial_s']:.1f} | {r['wall_s']:.0f} "
                     f"| {r['baseline_rms']:.3f} | {r['best_rms']:.3f} | {change:+.0f} % | {r['aborted']} "
                     f"| {r['unsafe']} | {r['failed']} | {len(r['changed_params'])} "
                     f"{', '.join(r['changed_params'][:5])} | {r.get('confirm_aborted', 0)} of "
                     f"{r.get('confirm_flown', 3)} |")
    body = "\n".join(lines)
    print(body)
    if not args.no_write:
        write_result("sitl-campaign", body)


if __name__ == "__main__":
    main()
