"""Benchmark: a whole `tune` campaign from the ground through a radio-like link.

For each stack: a fresh SITL at real time (a link's bandwidth is in wall-clock bytes per second, so a sped-up SITL
would send several times what a real vehicle does), our link emulator between it and the tuner
(``--shape``, default 4 kB/s down, 2 kB/s up, a 1 KB buffer, 5 % whole-frame loss), and
``ksbo-mav tune --budget N`` with the defaults. Reported: how the parameters came (path, time), the rate the link
check chose, flights, aborted / interrupted / link-lost trials, the campaign's wall time and, read afterwards over
a direct connection, every parameter left different from the snapshot (outside the autopilot-updated list).

    python scripts/bench_link_campaign.py [--budget 10] [--stacks ardupilot px4] [--shape SPEC] [--no-write]
    python scripts/bench_link_campaign.py --report   # results.md from the runs kept, the newest per stack

Each run is appended to ``benchmarks/link-campaign/runs.jsonl``; results.md shows the newest run of each stack
with the shape and budget asked for.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench_common import BENCH, append_record, changed_params, endpoint, machine, write_result  # noqa: E402

from ksbo_sim.linkproc import LinkEmulator  # noqa: E402
from ksbo_sim.process import free_udp_port  # noqa: E402
from ksbo_sim.sitl import start_sitl  # noqa: E402

RADIO = "down=4000,up=2000,queue=1024,loss=0.05,latency=0.02,seed=1,radio=1"


def run_one(kind: str, budget: int, shape: str, instance: int, rate: int | None = None) -> dict:
    work = Path(tempfile.mkdtemp(prefix=f"bench-link-{kind}-"))
    sitl = start_sitl(kind, instance=instance, speedup=1.0, workdir=work / "sitl")
    try:
        if kind == "px4":
            sitl.set_param("COM_RCL_EXCEPT", 4, int32=True)  # no RC in SITL: allow OFFBOARD without it
        _, ep = endpoint(sitl)
        gport = free_udp_port()
        # PX4's API link runs at 4 MB/s and would flood any radio; its 4000 B/s link stands for a radio port
        vehicle = f"tcp:127.0.0.1:{ep.port}" if kind == "ardupilot" else f"udpin:127.0.0.1:{sitl.radio_udp_port}"
        emu = LinkEmulator(vehicle, f"udp:127.0.0.1:{gport}", shape)
        d = work / "campaign"
        t0 = time.time()
        try:
            r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), "--udp", f"127.0.0.1:{gport}",
                                "--budget", str(budget), "--json", *(["--rate", str(rate)] if rate else [])],
                               capture_output=True, text=True, timeout=7200)
        finally:
            stats = emu.stop()
        wall = time.time() - t0
        log = r.stderr
        (work / "tune.log").write_text(log)  # the console, for a run that needs explaining
        params = re.search(r"parameters: (\d+) of (\d+) downloaded in ([\d.]+) s \(([^)]*)\)", log)
        lowered = re.search(r"link: flying at (\d+) Hz", log)
        row = {"kind": kind, "rc": r.returncode, "wall_s": wall, "params": params.groups() if params else None,
               "rate_hz": rate or (int(lowered.group(1)) if lowered else 50),
               "emulator": stats, "link_lost": log.count("link lost")}
        if r.returncode != 0:
            row["error"] = (log.strip().splitlines() or ["?"])[-1][:200]
        else:
            s = json.loads(r.stdout[r.stdout.index("{"):])
            recs = [json.loads(p.read_text()) for p in sorted((d / "trials").glob("trial_*.json"))]
            row.update(flights=len(recs), aborted=s["n_aborted"], unsafe=s["n_unsafe"],
                       interrupted=s.get("n_failed", 0), crashed=s.get("n_crashed", 0),
                       outcomes=sorted({str(x.get("outcome")) for x in recs}))
        row["changed_params"] = changed_params(sitl, d) if (d / "campaign.json").exists() else []
        return row
    finally:
        sitl.stop()


RUNS = BENCH / "link-campaign" / "runs.jsonl"


def row_of(r: dict) -> str:
    p = r["params"]
    pdesc = f"{p[0]} of {p[1]}, {p[2]} s, {p[3]}" if p else "-"
    dn = r["emulator"].get("down", {})
    return (f"| {r['kind']} | {r['at']} | {r['rc']}{' ' + r['error'] if 'error' in r else ''} | {pdesc} | "
            f"{r['rate_hz']} Hz | {r.get('flights', '-')} | {r.get('aborted', '-')} | {r.get('unsafe', '-')} "
            f"| {r.get('interrupted', '-')} | {r['link_lost']} | {r['wall_s']:.0f} | "
            f"{len(r['changed_params'])} {', '.join(r['changed_params'][:5])} | "
            f"{dn.get('lost', '?')} / {dn.get('dropped', '?')} |")


def report(budget: int, shape: str, write: bool) -> str:
    runs = [json.loads(ln) for ln in RUNS.read_text().splitlines() if ln.strip()] if RUNS.exists() else []
    newest: dict[str, dict] = {}
    for r in runs:
        if r.get("budget") == budget and r.get("shape") == shape:
            newest[r["kind"]] = r
    table = ["| stack | run (UTC) | exit | parameters (got of n, s, path) | rate flown | flights | aborted | unsafe "
             "| interrupted | 'link lost' | campaign wall (s) | params left changed | frames lost / dropped by the "
             "buffer (down) |", "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    table += [row_of(newest[k]) for k in ("ardupilot", "px4") if k in newest]
    machines = sorted({r["machine"].rsplit(",", 1)[0] for r in newest.values()})
    cmd = f"python scripts/bench_link_campaign.py --budget {budget} --shape {shape}"
    body = f"""Machine: {'; '.join(machines)}. Script: `{cmd}`
(runs in `runs.jsonl`; this page shows the newest of each stack).

## `tune --budget {budget}` from the ground through a radio-like link

SITLs at real time (1x) from shared/sitl, fresh parameters (PX4 through its MAVLink instance rated 4000 B/s, which
scales its streams as on a radio port; its API link runs at 4 MB/s); our link emulator
(`python -m ksbo_sim.linkemu`) between the SITL and the tuner with shape `{shape}`;
`ksbo-mav tune DIR --udp ... --budget {budget}` with the defaults and an empty parameter cache.
"params left changed": every parameter read back over a direct connection after the campaign, compared with the
snapshot (the autopilot's own calibration parameters excluded).

{chr(10).join(table)}
"""
    print(body)
    if write:
        write_result("link-campaign", body)
    return body


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--budget", type=int, default=10)
    ap.add_argument("--stacks", nargs="+", default=["ardupilot", "px4"], choices=["ardupilot", "px4"])
    ap.add_argument("--rate", type=int, default=None, help="pass `--rate HZ` to tune (default: the profile's)")
    ap.add_argument("--shape", default=RADIO, help=f"link emulator shape (default {RADIO})")
    ap.add_argument("--no-write", action="store_true", help="print only, do not write results.md")
    ap.add_argument("--report", action="store_true", help="only write results.md from the runs kept")
    a = ap.parse_args()
    if not a.report:
        for i, kind in enumerate(a.stacks):
            row = run_one(kind, a.budget, a.shape, instance=4 + i, rate=a.rate)
            append_record(RUNS, {**row, "budget": a.budget, "shape": a.shape, "machine": machine(),
                                 "at": time.strftime("%Y-%m-%d %H:%M", time.gmtime())})
    report(a.budget, a.shape, not a.no_write)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
