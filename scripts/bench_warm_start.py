"""Warm start: a campaign started from a finished one (`tune --warm-start EARLIER`) on a fresh vehicle of the same
profile, with nothing changed or with the vehicle changed (wind on ArduCopter SITL; drag on our JSBSim copter).

After the warm campaign, on the vehicle it left hovering, the baseline, the earlier campaign's recommendation and
the warm campaign's recommendation are flown in turn three times (B E W B E W B E W: the same condition). Records
the flights the warm campaign made, the first of its flights within the re-flight spread of the earlier result
(``reached_at``: flight number, the baseline being flight 1), what it said about the vehicle, and the re-flown
lap-2 RMS. One JSON line per run, appended to benchmarks/warm-start/runs.jsonl.

    python scripts/bench_warm_start.py --earlier DIR --stack ardupilot [--wind 6] [--budget 5]
    python scripts/bench_warm_start.py --earlier DIR --stack copter3d [--drag 1.5] [--budget 5]
    python scripts/bench_warm_start.py --report     # benchmarks/warm-start/results.md from the runs
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

os.environ.setdefault("MAVLINK20", "1")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

from _bench_common import append_record, machine, refly_in_turn  # noqa: E402

from ksbo_mav.mav.link import Endpoint  # noqa: E402

OUT = ROOT / "benchmarks" / "warm-start" / "runs.jsonl"


@contextmanager
def vehicle(a: argparse.Namespace):
    """(tune's connection arguments, Endpoint) of a fresh vehicle: ArduCopter SITL at -s 10 (wind set before the
    campaign) or our JSBSim copter in lockstep (drag set at start)."""
    if a.stack == "ardupilot":
        from ksbo_sim.sitl import start_sitl

        sitl = start_sitl("ardupilot", instance=a.instance, speedup=10.0)
        try:
            if a.wind:
                sitl.set_param("SIM_WIND_SPD", a.wind)
            yield sitl.cli_args, Endpoint("tcp", "127.0.0.1", sitl.tcp_port)
        finally:
            sitl.stop()
    else:
        from _bench_common import sim_and_endpoint

        extra = ["--drag", f"{a.drag}"] if a.drag != 1.0 else []
        with sim_and_endpoint("--vehicle", "copter3d", "--personality", "ardupilot", *extra) as (_sim, ep):
            yield ["--udp", f"127.0.0.1:{ep.port}"], ep


def run(a: argparse.Namespace) -> dict:
    earlier = json.loads((Path(a.earlier) / "result.json").read_text())["best"]["values"]
    d = Path(tempfile.mkdtemp(prefix="bench-warm-")) / "campaign"
    rec: dict = {"stack": a.stack, "earlier": a.earlier, "budget": a.budget, "wind_mps": a.wind, "drag": a.drag}
    with vehicle(a) as (args, ep):
        t0 = time.time()
        r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), *args, "--warm-start", a.earlier,
                            "--budget", str(a.budget), "--end", "hold", "--json"],
                           capture_output=True, text=True, timeout=3600)
        rec.update(rc=r.returncode, wall_s=round(time.time() - t0, 1))
        text = " ".join(r.stderr.split())  # the console wraps its lines
        i = text.find("warm start: the earlier recommendation")
        rec["said"] = text[i:text.find(" opt trial", i)] if i >= 0 else text[-300:]
        entries = [json.loads(x) for x in (d / "journal.jsonl").read_text().splitlines() if x.strip()]
        rec["flights"] = len(entries)
        rec["rms_per_flight"] = [round(e["rms"], 3) if e.get("rms") else None for e in entries]
        rec["unsafe"] = sum(e["kind"] == "opt" and e["P"] < 0 for e in entries)
        rec["aborted"] = sum(e["outcome"] not in ("ok",) for e in entries)
        if r.returncode == 0:
            warm = json.loads((d / "result.json").read_text())["best"]["values"]
            rec["reflown"] = refly_in_turn(d, ep, {"earlier": earlier, "warm": warm})
            e_rms = rec["reflown"]["earlier"]
            spread = max(e_rms) - min(e_rms)
            target = statistics.mean(e_rms) + max(spread, 0.005)
            rec["reached_at"] = next((i + 1 for i, x in enumerate(rec["rms_per_flight"]) if x is not None
                                      and i > 0 and x <= target), None)
    rec["machine"] = machine()
    return rec


def _mean(xs: list[float]) -> str:
    return f"{statistics.mean(xs):.3f}"


def report() -> None:
    """benchmarks/warm-start/results.md: one row per run of runs.jsonl."""
    runs = [json.loads(x) for x in OUT.read_text().splitlines() if x.strip()]
    rows = []
    for r in runs:
        if r.get("label", "").startswith("was-"):
            continue  # made with an earlier default (benchmarks/notes/short-campaign.md), not on the results page
        cond = (f"wind {r['wind_mps']:g} m/s" if r["wind_mps"] else f"drag x{r['drag']:g}" if r["drag"] != 1.0
                else "nothing changed")
        said = r["said"].split(": ", 1)[1] if ": " in r["said"] else r["said"]
        ref = r.get("reflown") or {}
        rows.append(f"| {'ArduCopter SITL' if r['stack'] == 'ardupilot' else 'JSBSim copter'} | {cond} | "
                    f"{r['flights']} | {r.get('reached_at') or '–'} | {said} | "
                    f"{_mean(ref['baseline']) if ref else '–'} | {_mean(ref['earlier']) if ref else '–'} | "
                    f"{_mean(ref['warm']) if ref else '–'} | {r['unsafe']} / {r['aborted']} |")
    text = "\n".join([
        "# Warm start: a campaign from a finished one",
        "",
        "Command: `python scripts/bench_warm_start.py --earlier DIR --stack ardupilot|copter3d [--wind MPS] [--drag "
        "X] --budget 5`, then `--report`. The earlier campaigns: today's default with `--budget 35` on the same "
        "profile (ArduCopter SITL calm, and our JSBSim copter static: the long runs of bench_short_campaign.py). "
        "Each warm campaign runs on a fresh vehicle; then the baseline (B), the earlier recommendation (E) and "
        "the warm one (W) are flown in turn three times on the vehicle it left hovering (B E W x3, the same "
        "condition; means below).",
        "",
        f"Machine: {runs[-1]['machine']}. Flights: every flight of the warm campaign (baseline, the earlier "
        "recommendation, optimiser trials, confirmation). Reached at: the first of its flights (the baseline "
        "being 1) whose lap-2 RMS is within the re-flight spread of E's.",
        "",
        "| vehicle | condition | flights | reached at | what it said | B (m) | E (m) | W (m) | unsafe / aborted |",
        "|---|---|---|---|---|---|---|---|---|",
        *rows,
        "",
    ])
    (OUT.parent / "results.md").write_text(text)
    print(f"wrote {OUT.parent / 'results.md'}")


def main() -> None:
    if "--report" in sys.argv:
        report()
        return
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--earlier", required=True, help="the finished campaign to start from")
    ap.add_argument("--stack", choices=("ardupilot", "copter3d"), default="ardupilot")
    ap.add_argument("--budget", type=int, default=5)
    ap.add_argument("--wind", type=float, default=0.0, help="ArduCopter SITL: SIM_WIND_SPD for the warm campaign")
    ap.add_argument("--drag", type=float, default=1.0, help="copter3d: the drag, times as built")
    ap.add_argument("--instance", type=int, default=12)
    a = ap.parse_args()
    r = run(a)
    append_record(OUT, r)


if __name__ == "__main__":
    main()
