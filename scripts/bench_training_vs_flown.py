"""Benchmark: why the training score and an independent flight differ. One ArduCopter SITL, the baseline and a
tuned gain set (a finished campaign's recommendation), each flown several times, in turn, on:

* ``streamed``: the training trial, through the tuner's own MavlinkObjective (the figure-8 streamed from the
  ground on the vehicle's clock, pos+vel+acc, content half a step ahead of its send time on ArduPilot);
* ``onboard``: the same trial flown on board by the onboard guard's Lua script;
* ``client``, ``client+lead10``, ``client-ff``, ``client10hz``: the same figure-8 streamed by the separate client
  ``scripts/figure8_client.py`` (pymavlink only) answering each LOCAL_POSITION_NED sample with the setpoint of its
  stamp: no lead / 10 ms lead (the tuner's half step) / position-only (no feed-forward) / every 5th sample (10 Hz);
* ``steps``, ``hold``, ``auto_mission``: the profile's validation manoeuvres (full sizes) through
  ``fly_manoeuvre``: GUIDED position steps, LOITER hold, an AUTO box mission on the autopilot's own navigation.

Every figure-8 is scored the same way as well: lap-2 3-D RMS of the measured position against the pattern at the
sample's own stamp (``true_rms``), next to the tuner's own score where it has one. A record per run goes to
``benchmarks/training-vs-flown/runs.jsonl``.

    python scripts/bench_training_vs_flown.py --campaign DIR [--reps 3] [--speedup 10] [--sources ...]
    python scripts/bench_training_vs_flown.py --tuned 1.75,3.5,1,0.25,1,5 ...
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import socket
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("MAVLINK20", "1")
HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _bench_common import BENCH, append_record, machine, write_result  # noqa: E402
from ksbo_sim.sitl_instances import start_claimed  # noqa: E402

from ksbo_mav.campaign.mission_rate import check_link  # noqa: E402
from ksbo_mav.campaign.onboard import guard_link_timeout  # noqa: E402
from ksbo_mav.errors import TrialStopped  # noqa: E402
from ksbo_mav.mav.guard_script import config_for, figure8_for, new_config_id  # noqa: E402
from ksbo_mav.mav.link import Endpoint  # noqa: E402
from ksbo_mav.mav.monitor import Monitor, limits_from_profile  # noqa: E402
from ksbo_mav.mav.objective import MavlinkObjective  # noqa: E402
from ksbo_mav.mav.onboard_guard import OnboardGuard  # noqa: E402
from ksbo_mav.mav.tlog import read_tlog  # noqa: E402
from ksbo_mav.mav.validation import ManoeuvreSpec, fly_manoeuvre  # noqa: E402
from ksbo_mav.mav.vehicle import Vehicle  # noqa: E402

RUNS = BENCH / "training-vs-flown" / "runs.jsonl"
CLIENTS = {"client": [], "client+lead10": ["--lead-ms", "10"], "client-ff": ["--no-feed-forward"],
           "client10hz": ["--every", "5"]}
SOURCES = ("streamed", "onboard", *CLIENTS, "steps", "hold", "auto_mission")


def true_rms(tlog: Path, mission) -> float | None:
    """Lap-2 3-D RMS of a tuner trial's received LOCAL_POSITION_NED against the pattern at each sample's stamp
    (t0 from the trial's start marker), as the separate client scores itself."""
    from ksbo_mav.mav.trajectory import trajectory_from_tlog

    recs = read_tlog(tlog)
    _, info, _ = trajectory_from_tlog(recs)
    t0 = info.get("t0_ms")
    if t0 is None:
        return None
    f8 = mission.figure8h
    t, pos = [], []
    for r in recs:
        if not r.sent and r.msg.get_type() == "LOCAL_POSITION_NED":
            t.append((r.msg.time_boot_ms - t0) / 1000.0)
            pos.append((r.msg.x, r.msg.y, r.msg.z))
    t, pos = np.array(t), np.array(pos)
    dt = mission.dt
    sel = (t > f8.duration - f8.period + 0.5 * dt) & (t <= f8.duration + 0.5 * dt)
    if sel.sum() < 50:
        return None
    d = np.linalg.norm(pos[sel] - f8.position(np.minimum(t[sel], f8.duration)), axis=1)
    return float(np.sqrt(np.mean(d * d)))


def centre_sticks(instance: int) -> None:
    """The SITL's simulated transmitter with sticks 1-4 centred (its throttle rests at 1000 us otherwise, and
    LOITER, the hold manoeuvre, follows the throttle stick): one RC packet to its RC input port 5501+10N."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.sendto(struct.pack("<16H", *([1500] * 4 + [0] * 12)), ("127.0.0.1", 5501 + 10 * instance))


def fly_client(v: Vehicle, port: int, extra: list[str], out: Path) -> dict:
    """The separate client on the SITL's spare port, the tuner's link pumped meanwhile (its heartbeat goes on)."""
    m = v.mission
    cmd = [sys.executable, str(HERE / "figure8_client.py"), "--tcp", f"127.0.0.1:{port}", "--scale", str(m.scale),
           "--scale-east", str(m.scale2), "--period", str(m.period), "--up", str(m.center_up), "--laps",
           str(m.laps), "--lead-in", str(m.lead_in), "--samples-out", str(out), *extra]
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    while p.poll() is None:
        v.link.pump(0.02)
    so, se = p.communicate()
    if p.returncode != 0:
        return {"error": (se.strip().splitlines() or ["?"])[-1]}
    return json.loads(so.strip().splitlines()[-1])


def run(a: argparse.Namespace) -> dict:
    work = Path(tempfile.mkdtemp(prefix="bench-training-vs-flown-"))
    sitl = start_claimed("ardupilot", a.speedup, workdir=work / "sitl")
    log = lambda s: print(s, file=sys.stderr, flush=True)  # noqa: E731
    rows: list[dict] = []
    try:
        for k, val in (s.split("=") for s in a.set):
            sitl.set_param(k, float(val))
        v = Vehicle.connect(Endpoint("tcp", "127.0.0.1", sitl.tcp_port), "ardupilot-copter", log=log)
        try:
            check_link(v, log)
            base = {n: v.params.read(n) for n in v.gain_map.param_names}
            x0 = v.gain_map.from_params(base)
            tuned = np.array(a.tuned_x, float)
            limits = limits_from_profile(v.profile)
            guard = OnboardGuard(v.link, v.params, v.cmd, log)
            guard.install(config_for(limits, guard_link_timeout(v, log), base, new_config_id(),
                                     figure8=figure8_for(v.mission, 1.5 * limits.tracking_error_max)))
            v.guard = guard
            v.ensure_airborne(log=log)
            centre_sticks(sitl.instance)
            obj = MavlinkObjective(v, base, work / "trials", log=log)
            monitor = Monitor(limits, v.stack.modes["guided"], v.stack.mode_name)
            vspec = v.profile.validation_spec
            specs = {k: ManoeuvreSpec.from_dict(k, vspec.sizes(k)) for k in vspec.kinds}
            sets = (("baseline", x0), ("tuned", tuned))
            n = 0
            for rep in range(a.reps):
                for name, x in (sets if rep % 2 == 0 else sets[::-1]):
                    for src in a.sources:
                        n += 1
                        row = {"rep": rep, "set": name, "source": src}
                        if src in ("streamed", "onboard"):
                            obj.trial_flight.on_board = src == "onboard"
                            try:
                                f = obj.fly(x, label=f"{name}/{src}")
                            except TrialStopped as exc:  # e.g. the tuner fell behind: recorded, not scored
                                row.update(outcome="stopped", message=str(exc))
                                rows.append(row)
                                print(json.dumps(row), flush=True)
                                continue
                            row.update(outcome=str(f.outcome.value), tool_rms=f.score.get("rms_lap2_m"),
                                       true_rms=true_rms(Path(f.meta["tlog"]), v.mission),
                                       lag_max_ms=f.meta["link"].get("lag_max_ms"),
                                       late_fraction=f.meta["link"].get("late_fraction"))
                        elif src in CLIENTS:
                            v.write_gains(x)
                            row.update(fly_client(v, sitl.tcp_ports[1], CLIENTS[src], work / f"client-{n}.json"))
                            row["true_rms"] = row.get("rms_lap2_m")
                            v.write_gains(x0)
                        else:
                            f = fly_manoeuvre(v, specs[src], monitor, gains_label=name,
                                              tlog_path=work / f"val-{n}-{src}.tlog", gains=x,
                                              baseline_params=base, log=log)
                            row.update(outcome=str(f.outcome.value), metrics=f.metrics, message=f.message)
                        rows.append(row)
                        print(json.dumps(row, default=_nan), flush=True)
            v.guard = None
            guard.remove()
            v.land()
        finally:
            v.close()
    finally:
        sitl.stop()
    return {"speedup": a.speedup, "reps": a.reps, "baseline": x0.tolist(), "tuned": tuned.tolist(),
            "tuned_from": a.campaign or a.tuned_from, "sitl_set": a.set, "rows": rows, "work": str(work)}


def _nan(o):
    return None if isinstance(o, float) and o != o else str(o)


#: What each source's row reports: (figure, what it is).
FIGURES = {"steps": ("settle_s_mean", "steps: mean settling time (s)"),
           "hold": ("hold_rms_m", "LOITER hold: RMS drift (m)"),
           "auto_mission": ("xtrack_rms_m", "AUTO box: cross-track RMS (m)")}
LABELS = {"streamed": "training trial, streamed by the tuner (its score)",
          "onboard": "training trial flown on board (Lua, a target every 10 ms)",
          "client": "separate client, answers each sample, no lead",
          "client+lead10": "separate client, 10 ms lead",
          "client-ff": "separate client, position only (no feed-forward)",
          "client10hz": "separate client, every 5th sample (10 Hz)"}


def _figure(row: dict) -> float | None:
    if row["source"] in FIGURES:
        return (row.get("metrics") or {}).get(FIGURES[row["source"]][0])
    return row.get("true_rms")


def report(write: bool) -> str:
    runs = [json.loads(ln) for ln in RUNS.read_text().splitlines() if ln.strip()] if RUNS.exists() else []
    full = [r for r in runs if r["reps"] >= 2]
    newest = {(r["speedup"], tuple(r["sitl_set"])): r for r in full}  # per speed-up and SITL settings
    shown = sorted(newest.values(), key=lambda r: -len({row["source"] for row in r["rows"]}))  # fullest first
    lines = []
    for r in shown:
        lines += [f"### SITL ×{r['speedup']:g}, {r['reps']} flights per cell, alternated (run {r['at']})"
                  + (f", SITL {' '.join(r['sitl_set'])}" if r["sitl_set"] else ""), "",
                  "| flown as | figure | baseline: mean (min–max) | tuned: mean (min–max) | change | not scored |",
                  "|---|---|---|---|---|---|"]
        for src in dict.fromkeys(row["source"] for row in r["rows"]):
            cells, bad = {}, 0
            for name in ("baseline", "tuned"):
                vals = [v for row in r["rows"] if row["source"] == src and row["set"] == name
                        if (v := _figure(row)) is not None]
                bad += sum(1 for row in r["rows"] if row["source"] == src and row["set"] == name) - len(vals)
                cells[name] = vals
            b, t = cells["baseline"], cells["tuned"]
            fmt = lambda v: f"{statistics.mean(v):.4g} ({min(v):.4g}–{max(v):.4g})" if v else "–"  # noqa: E731
            change = f"{statistics.mean(t) / statistics.mean(b) - 1:+.0%}" if b and t else "–"
            what = FIGURES[src][1] if src in FIGURES else "lap-2 RMS vs the pattern (m)"
            lines.append(f"| {LABELS.get(src, src)} | {what} | {fmt(b)} | {fmt(t)} | {change} | {bad} |")
        lines += ["", f"Tuned gains: {', '.join(f'{v:.3g}' for v in r['tuned'])} ({r['tuned_from']}); baseline "
                  f"{', '.join(f'{v:.3g}' for v in r['baseline'])}.", ""]
    newest = shown[-1] if shown else None
    for r in full:
        newest = r if newest is None or r["at"] > newest["at"] else newest
    body = (f"Machine: {newest['machine'] if newest else '–'} (newest run). Script: "
            "`python scripts/bench_training_vs_flown.py --tuned X --reps 3 --speedup S [--set SIM_WIND_SPD=5 ...]`; "
            "reading: `docs/training-trial.md`.\n\n" + "\n".join(lines)
            + "\nRuns in `runs.jsonl`; shown: the newest run with 2+ repeats per speed-up and SITL settings, the one "
            "with the most sources first. ArduCopter SITL, calm unless the SITL settings say otherwise; in each run "
            "the two gain sets are flown alternately (A B A B) on every row. Figure-8 rows: lap-2 3-D RMS of the "
            "measured position against the pattern at each sample's own stamp (for the tuner's trials this equals "
            "its own score to 1e-6 m). Not scored: a trial the tuner stopped because it fell behind the vehicle "
            "(the loaded machine), a client flight that did not finish.")
    print(body)
    if write:
        write_result("training-vs-flown", body)
    return body


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--campaign", help="a finished campaign's directory: its recommendation is the tuned set")
    ap.add_argument("--tuned", help="the tuned gain vector, comma-separated, in the profile's gain order")
    ap.add_argument("--tuned-from", default="--tuned", help="where the --tuned gains came from (for the record)")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--speedup", type=float, default=10.0)
    ap.add_argument("--sources", default=",".join(SOURCES), help=f"comma-separated, of {', '.join(SOURCES)}")
    ap.add_argument("--set", action="append", default=[], metavar="SIM_PARAM=VALUE",
                    help="a SITL parameter set before flying (repeatable), e.g. SIM_WIND_SPD=5")
    ap.add_argument("--report", action="store_true", help="only write results.md from the runs kept")
    a = ap.parse_args()
    if a.report:
        report(True)
        return 0
    a.sources = [s for s in a.sources.split(",") if s]
    if bad := [s for s in a.sources if s not in SOURCES]:
        ap.error(f"unknown source {bad[0]}")
    if a.campaign:
        a.tuned_x = json.loads((Path(a.campaign) / "result.json").read_text())["best"]["x"]
    elif a.tuned:
        a.tuned_x = [float(s) for s in a.tuned.split(",")]
    else:
        ap.error("give --campaign DIR or --tuned")
    rec = run(a)
    append_record(RUNS, {**rec, "machine": machine(), "at": time.strftime("%Y-%m-%d %H:%M", time.gmtime())})
    report(True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
