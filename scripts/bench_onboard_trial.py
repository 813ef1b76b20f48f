"""Benchmark: the figure-8 flown on board by the onboard guard against the figure-8 streamed from the ground.

On a fresh ArduCopter SITL booted with Lua scripting, at real time (a radio's bandwidth is in wall-clock bytes per
second): connect as ``ksbo-mav tune`` does (over a direct TCP link, or through our link emulator shaped like a thin
telemetry radio, ``--shape``), run the campaign's link check (which lowers the ground stream's mission rate where
the link cannot carry it), install the onboard guard rendered with the campaign's figure-8, take off, then fly each
gain set ``--reps`` times as an onboard trial and as a ground-streamed trial, in turn (onboard, ground, onboard, ...
so a slow drift of the vehicle falls on both), every one through the tuner's own MavlinkObjective (same mission,
monitor, guard armed, scoring and restore). Reported per gain set and source: the lap-2 RMS of every flight, their
mean and spread, and P scored as a campaign would (against the baseline's mean RMS flown the same way).

    python scripts/bench_onboard_trial.py --link direct [--reps 3]
    python scripts/bench_onboard_trial.py --link radio [--shape SPEC]
    python scripts/bench_onboard_trial.py --report        # results.md from the runs kept

Each run is appended to ``benchmarks/onboard-trial/runs.jsonl``; results.md shows the newest run of each link.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")
HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _bench_common import BENCH, append_record, machine, write_result  # noqa: E402
from bench_link_campaign import RADIO  # noqa: E402
from ksbo_sim.sitl_instances import start_claimed  # noqa: E402

from ksbo_mav.campaign.mission_rate import check_link  # noqa: E402
from ksbo_mav.errors import KsboError  # noqa: E402
from ksbo_mav.mav.guard_script import config_for, figure8_for, new_config_id  # noqa: E402
from ksbo_mav.mav.link import Endpoint  # noqa: E402
from ksbo_mav.mav.monitor import limits_from_profile  # noqa: E402
from ksbo_mav.mav.objective import MavlinkObjective  # noqa: E402
from ksbo_mav.mav.onboard_guard import OnboardGuard  # noqa: E402
from ksbo_mav.mav.vehicle import Vehicle  # noqa: E402
from ksbo_sim.linkproc import LinkEmulator  # noqa: E402
from ksbo_sim.process import free_udp_port  # noqa: E402

RUNS = BENCH / "onboard-trial" / "runs.jsonl"
#: Gain sets (changes to the SITL's defaults): the defaults, and two the SITL fact sheet measured as better.
GAIN_SETS = {"baseline": {}, "posxy_p_1.75": {"PSC_POSXY_P": 1.75},
             "posxy_p_1.75+velxy_p_3.5": {"PSC_POSXY_P": 1.75, "PSC_VELXY_P": 3.5}}
SOURCES = ("onboard", "ground")


def run(link: str, reps: int, shape: str, speedup: float) -> dict:
    work = Path(tempfile.mkdtemp(prefix=f"bench-onboard-{link}-"))
    sitl = start_claimed("ardupilot", speedup, workdir=work / "sitl")
    emu = None
    log_lines: list[str] = []

    def log(s: str) -> None:
        log_lines.append(s)
        print(s, file=sys.stderr, flush=True)

    try:
        if link == "radio":
            gport = free_udp_port()
            emu = LinkEmulator(f"tcp:127.0.0.1:{sitl.tcp_port}", f"udp:127.0.0.1:{gport}", shape)
            ep = Endpoint("udp", "127.0.0.1", gport)
        else:
            ep = Endpoint("tcp", "127.0.0.1", sitl.tcp_port)
        v = Vehicle.connect(ep, "ardupilot-copter", log=log)
        try:
            check_link(v, log)
            base = {n: v.params.read(n) for n in v.gain_map.param_names}
            limits = limits_from_profile(v.profile)
            guard = OnboardGuard(v.link, v.params, v.cmd, log)
            guard.install(config_for(limits, v.heartbeat_timeout, base, new_config_id(),
                                     figure8=figure8_for(v.mission, 1.5 * limits.tracking_error_max)))
            v.guard = guard
            v.ensure_airborne(log=log)
            obj = MavlinkObjective(v, base, work / "trials", log=log)
            flights: dict[str, dict[str, list[dict]]] = {g: {s: [] for s in SOURCES} for g in GAIN_SETS}
            for rep in range(reps):
                for name, changes in GAIN_SETS.items():
                    x = v.gain_map.from_params({**base, **changes})
                    for source in (SOURCES if rep % 2 == 0 else SOURCES[::-1]):
                        obj.trial_flight.on_board = source == "onboard"
                        f = obj.fly(x, label=f"{name}/{source}")
                        row = {"rms": f.score.get("rms_lap2_m"), "outcome": str(f.outcome.value),
                               "message": f.meta["message"], "lost": f.meta["link"]["lost_packets"],
                               "samples": f.score.get("samples"), "wall_s": round(f.meta["wall_s"], 1)}
                        done = [t for t in guard.texts if "figure-8 done" in t]
                        if source == "onboard" and done:  # "KSG: figure-8 done, N targets": the script's rate
                            row["targets"] = int(done[-1].split(", ")[1].split()[0])
                            guard.texts.clear()
                        flights[name][source].append(row)
                        print(json.dumps({"link": link, "set": name, "source": source, **row}), flush=True)
            v.guard = None
            try:
                guard.remove()
            except KsboError as exc:  # the flights are measured; a SITL thrown away keeps the script
                log(f"onboard guard not removed: {exc}")
            v.land()
        finally:
            v.close()
        return {"link": link, "shape": shape if link == "radio" else "", "reps": reps, "speedup": speedup,
                "rate_hz": v.mission.rate_hz, "flights": flights,
                "emulator": emu.stop() if emu is not None else None, "gain_sets": GAIN_SETS}
    finally:
        if emu is not None:
            emu.stop()
        sitl.stop()


def _summary(flights: dict[str, list[dict]], ref: float | None) -> tuple[str, str, str]:
    ok = [r["rms"] for r in flights if r["rms"] is not None]
    bad = len(flights) - len(ok)
    if not ok:
        return "-", "-", f"{bad} of {len(flights)} not scored"
    mean = statistics.mean(ok)
    spread = f"{min(ok):.4f}–{max(ok):.4f}" if len(ok) > 1 else f"{ok[0]:.4f}"
    p = f"{1 - mean / (2 * ref):.3f}" if ref else "-"
    return f"{mean:.4f} ({spread})", p, f"{bad} of {len(flights)}" if bad else "0"


def report(write: bool) -> str:
    runs = [json.loads(ln) for ln in RUNS.read_text().splitlines() if ln.strip()] if RUNS.exists() else []
    newest = {r["link"]: r for r in runs}
    lines = ["| link | gain set | lap-2 RMS (m) onboard: mean (min–max) | ground | P onboard | P ground "
             "| not scored (onboard / ground) |", "|---|---|---|---|---|---|---|"]
    for link in ("direct", "radio"):
        r = newest.get(link)
        if r is None:
            continue
        for name in r["flights"]:
            cells = {}
            for source in SOURCES:
                base = [x["rms"] for x in r["flights"]["baseline"][source] if x["rms"] is not None]
                cells[source] = _summary(r["flights"][name][source], statistics.mean(base) if base else None)
            (rb, pb, bb), (rg, pg, bg) = cells["onboard"], cells["ground"]
            lines.append(f"| {link} | {name} | {rb} | {rg} | {pb} | {pg} | {bb} / {bg} |")
    links = [f"*{k}*: " + ("direct TCP" if k == "direct" else f"the link emulator `{r['shape']}`")
             + f", ground stream at {r['rate_hz']} Hz, SITL -s {r['speedup']:g}, {r['reps']} flights per cell "
             f"(run {r['at']})" for k, r in sorted(newest.items())]
    machines = sorted({r["machine"].rsplit(",", 1)[0] for r in newest.values()})  # (without the date)
    body = (f"Machine: {'; '.join(machines)}. Script: "
            "`python scripts/bench_onboard_trial.py --link direct|radio` (runs in `runs.jsonl`, newest per link).\n\n"
            "ArduCopter SITL with scripting, at real time; every flight a full trial through the tuner's "
            "MavlinkObjective with the onboard guard armed: *onboard* = the guard's script flies the figure-8 "
            "(`trial_source = onboard`), *ground* = the tuner streams it at the mission rate the link check "
            "left. Same figure-8 and lead-in, same monitor and scoring (lap-2 3-D RMS; P = 1 − RMS / (2 × the "
            "baseline's RMS), as a campaign scores against its own baseline flight). Gain sets: "
            + "; ".join(f"{k} {v or '(the defaults)'}" for k, v in GAIN_SETS.items()) + ". "
            + "; ".join(links) + ".\n\n" + "\n".join(lines) + "\n")
    print(body)
    if write:
        write_result("onboard-trial", body)
    return body


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--link", choices=["direct", "radio"], default="direct")
    ap.add_argument("--reps", type=int, default=3, help="flights per gain set and source (default 3)")
    ap.add_argument("--shape", default=RADIO, help=f"link emulator shape for --link radio (default {RADIO})")
    ap.add_argument("--speedup", type=float, default=1.0, help="SITL speed-up (default 1: real time)")
    ap.add_argument("--no-write", action="store_true", help="print only, do not write results.md")
    ap.add_argument("--report", action="store_true", help="only write results.md from the runs kept")
    a = ap.parse_args()
    if not a.report:
        row = run(a.link, a.reps, a.shape, a.speedup)
        append_record(RUNS, {**row, "machine": machine(), "at": time.strftime("%Y-%m-%d %H:%M", time.gmtime())})
    report(not a.no_write)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
