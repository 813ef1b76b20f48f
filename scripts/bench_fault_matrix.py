"""Benchmark: the fault matrix on ArduCopter SITL with the onboard guard.

Each case is a fresh SITL (-s 10, Lua scripting on), the tuner (``ksbo-mav tune``, a short campaign with its quick
validation: a budget of 2 (the baseline, one optimiser trial), one confirmation, small validation manoeuvres flown
twice with each gain set) behind the link emulator, a second MAVLink
connection the tuner does not use (what the vehicle does), and, in the "pilot" cases, the bench pilot
(``ksbo-mav sim-pilot``) holding the sticks. At the case's phase (takeoff, mid-trial, between trials, the
confirmation flight, the validation's LOITER hold, its AUTO mission) the fault strikes: the link cut for 8 s of wall
time (80 s of vehicle time) and given back, or the tuner killed (SIGKILL). Recorded: what the vehicle did (mode,
arming, the guard, on the second connection), how long the trial gains flew after the fault, the gains and mode
left, the tuner's exit status and last words; then what continues it (after a kill: ``restore``, then the command
it prints; after a cut the tuner goes on by itself, or the command its stop printed), and finally every parameter
against the campaign's snapshot.

    python scripts/bench_fault_matrix.py [--cases kill-takeoff-pilot,...] [--write]

Run it through /work/bin/heavy (it flies a SITL); records go to benchmarks/fault-matrix/runs.jsonl, the table to
benchmarks/fault-matrix/results.md (``--write``, from every recorded case).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench_common import BENCH, machine, write_result  # noqa: E402
from _fault_table import table  # noqa: E402
from _fault_watch import Watch  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OUT = BENCH / "fault-matrix"
PHASES = ("takeoff", "mid-trial", "between-trials", "confirmation", "hold", "auto")
CUT_S = 8.0
OBSERVE_S = 12.0
SMALL = """
[validation]
manoeuvres = "steps,hold,auto_mission"
repeats = 2

[validation.steps]
offsets_m = [[3.0, 0.0, 0.0]]
dwell_s = 6.0
settle_s = 1.0

[validation.hold]
seconds = 6.0
settle_s = 1.0

[validation.auto_mission]
size_m = [4.0, 3.0]
settle_s = 1.0
"""


def cases() -> list[str]:
    return [f"{fault}-{phase}-{who}" for fault in ("kill", "cut") for phase in PHASES for who in ("pilot", "alone")]


def profile(tmp: Path) -> Path:
    text = (ROOT / "params" / "ardupilot-copter.toml").read_text()
    p = tmp / "small-validation.toml"
    p.write_text(text[:text.index("[validation]")] + SMALL)
    return p


def tool(*args: str, timeout: float = 900) -> tuple[int, str]:
    r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", *args], capture_output=True, text=True, timeout=timeout)
    return r.returncode, r.stdout + r.stderr


def lines(path: Path) -> list[dict]:
    return [json.loads(x) for x in path.read_text().splitlines() if x.strip()] if path.exists() else []


def reached(phase: str, d: Path, w: Watch, started: dict) -> bool | None:
    """Whether the fault's moment has come (None: it never will: the hold refused without a pilot)."""
    journal, tlogs = lines(d / "journal.jsonl"), sorted((d / "trials").glob("trial_*.tlog"))
    now = time.monotonic()
    if phase == "takeoff":
        return bool(w.armed and w.height is not None and 1.0 < w.height < 7.0 and not tlogs)
    if phase == "between-trials":
        return len(journal) >= 2
    if phase in ("mid-trial", "confirmation"):
        want = 1 if phase == "mid-trial" else 2  # trial 1 an optimiser trial, trial 2 the confirmation
        if len(journal) >= want and len(tlogs) > want and "at" not in started:
            started["at"] = now
        return "at" in started and now - started["at"] >= 2.0
    flights = lines(d / "validation.jsonl")
    if phase == "hold":
        if any(f["manoeuvre"] == "hold" and f["outcome"] == "error" for f in flights):
            return None
        if w.mode == 5 and (d / "validation").exists() and "at" not in started:
            started["at"] = now
    if phase == "auto" and w.mode == 3 and "at" not in started:
        started["at"] = now
    # (the small hold lasts 6 s of vehicle time, 0.6 s of wall time at 10x: the fault strikes as it begins)
    return "at" in started and now - started["at"] >= (0.0 if phase == "hold" else 0.3)


def recommend_other(d: Path) -> str:
    """A finished campaign's recommendation moved a quarter of the way to the top of its search box (inside the
    trust region), so that ``validate`` has something to compare: a random search of two flights often recommends
    the baseline itself, and then no validation flight is flown."""
    settings, result = json.loads((d / "campaign.json").read_text()), json.loads((d / "result.json").read_text())
    x0, hi = settings["x0"], [b[1] for b in settings["bounds"]]
    names = list(settings["baseline"])
    x = [a + 0.25 * (h - a) for a, h in zip(x0, hi)]
    values = {n: settings["baseline"][n] * (xi / a if a else 1.0) for n, xi, a in zip(names, x, x0)}
    result["best"].update(x=x, values=values)
    (d / "result.json").write_text(json.dumps(result))
    return ", ".join(f"{n} {v:.4g}" for n, v in values.items())


def read_all_params(sitl) -> tuple[dict[str, float], bool]:
    """Every parameter (a fresh download on the second port) and whether the vehicle is armed."""
    from ksbo_mav.mav.link import Endpoint
    from ksbo_mav.mav.vehicle import Vehicle

    from ksbo_mav.mav.mission_transfer import MissionTransfer

    v = Vehicle.connect(Endpoint("tcp", "127.0.0.1", sitl.tcp_ports[1]), "ardupilot-copter", sysid=250, compid=190)
    try:
        hb = v.link.wait_heartbeat(5.0)
        items = len(MissionTransfer(v.link).download())
        return {**{n: p.value for n, p in v.params.table.items()}, "_mission_items": items}, bool(hb.base_mode & 128)
    finally:
        v.close()


def param_diff(d: Path, now: dict[str, float]) -> dict[str, tuple[float, float | None]]:
    """Parameters off the campaign's snapshot (those the autopilot writes itself aside)."""
    from ksbo_mav.mav.params import load_snapshot
    from ksbo_mav.mav.stacks import autopilot_updated

    if not (d / "snapshot").exists():
        return {}
    snap = load_snapshot(d)
    return {n: (v, now.get(n)) for n, (v, _) in snap.params.items() if not autopilot_updated(snap.stack, n)
            and (n not in now or abs(now[n] - v) > 1e-6 * max(1.0, abs(v)))}


def gains_text(now: dict[str, float], base: dict[str, float]) -> str:
    if len(now) < len(base):
        return f"not read ({len(now)} of {len(base)} answered)"
    same = sum(abs(now[n] - base[n]) <= 1e-6 * max(1.0, abs(base[n])) for n in base if n in now)
    return "baseline" if same == len(base) else f"trial ({len(base) - same} of {len(base)} off the baseline)"


def run_case(name: str, speed: float, tmp: Path) -> dict:
    """One case on a fresh SITL, everything it started stopped at the end."""
    from ksbo_sim.sitl_instances import release_stopped, start_claimed

    sitl = start_claimed("ardupilot", speed)
    stoppers: list = []  # what this case started, stopped at its end however it ends
    try:
        return _fly_case(name, sitl, tmp, stoppers)
    finally:
        for stop_it in reversed(stoppers):
            try:
                stop_it()
            except Exception as exc:  # noqa: BLE001 - the next case must start clean
                print(f"clean-up: {exc}")
        sitl.stop()
        release_stopped()


def _fly_case(name: str, sitl, tmp: Path, stoppers: list) -> dict:
    from ksbo_sim.bench_pilot import PilotProcess
    from ksbo_sim.linkproc import LinkEmulator
    from ksbo_sim.process import free_udp_port

    fault, phase, who = name.split("-", 1)[0], name.split("-", 1)[1].rsplit("-", 1)[0], name.rsplit("-", 1)[1]
    rec: dict = {"case": name, "fault": fault, "phase": phase, "pilot": who == "pilot"}
    gport = free_udp_port()
    emu = LinkEmulator(f"tcp:127.0.0.1:{sitl.tcp_port}", f"udp:127.0.0.1:{gport}", startup_timeout=120)
    stoppers.append(emu.stop)
    if who == "pilot":
        stoppers.append(PilotProcess(f"tcp:127.0.0.1:{sitl.tcp_ports[2]}", startup_timeout=120).stop)
    w = Watch(f"tcp:127.0.0.1:{sitl.tcp_ports[1]}")
    stoppers.append(w.close)
    conn = ["--udp", f"127.0.0.1:{gport}"]
    d = tmp / name
    log = open(tmp / f"{name}.tune.txt", "w")
    tune = [sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), *conn, "--profile", str(profile(tmp)), "--budget",
            "2", "--confirm", "1", "--prior", "none", "--method", "random", "--validation", "quick"]
    if phase in ("hold", "auto"):  # the validation flights of a recommendation that is not the baseline
        rc, out = tool(*tune[3:-1], "off")
        if not (d / "result.json").is_file():
            raise RuntimeError(f"the setup tune (--validation off) ended with exit {rc}: {out[-600:]}")
        rec["setup"] = f"tune --validation off: exit {rc}; recommendation set to {recommend_other(d)}"
        tune = [sys.executable, "-m", "ksbo_mav.cli", "validate", str(d), *conn]
    proc = subprocess.Popen(tune, stdout=log, stderr=subprocess.STDOUT, text=True)
    stoppers.append(lambda: proc.kill() if proc.poll() is None else None)
    try:
        started: dict = {}
        deadline, moment = time.monotonic() + 900, False
        while time.monotonic() < deadline and proc.poll() is None:
            moment = reached(phase, d, w, started)
            if moment is not False:
                break
            w.pump(0.1)
        base = json.loads((d / "campaign.json").read_text())["baseline"] if (d / "campaign.json").exists() else {}
        if moment is not True:
            rec["reached"] = False
            rec["note"] = ("the hold refused (the SITL's throttle rests low): no LOITER to fault" if moment is None
                           else f"phase not reached (tuner exit {proc.poll()})")
            proc.wait(900)
        else:
            rec["reached"] = True
            names = sorted(base)
            t0_ms, t0 = w.vehicle_ms, time.monotonic()
            rec["gains_at_fault"] = gains_text(w.params(names, tries=1), base)
            rec["mode_at_fault"], rec["height_at_fault_m"] = w.mode_name(), w.height
            w.events.clear()
            if fault == "kill":
                proc.kill()
            else:
                emu.cut()
            back_ms = None
            while time.monotonic() - t0 < (CUT_S if fault == "cut" else OBSERVE_S):
                now = w.params(names, tries=1)
                if back_ms is None and now and gains_text(now, base) == "baseline":
                    back_ms = w.vehicle_ms - t0_ms
                w.pump(0.3)
            rec["trial_gains_after_fault_s"] = None if back_ms is None else round(back_ms / 1000.0, 1)
            rec["vehicle"] = [f"{(t - t0_ms) / 1000.0:+.1f} s {what}" for t, what in w.events if t >= t0_ms]
            rec["left"] = {"mode": w.mode_name(), "armed": w.armed, "height_m": w.height,
                           "gains": gains_text(w.params(names), base)}
            if fault == "cut":
                emu.reconnect()
            proc.wait(900)
        log.close()
        said = (tmp / f"{name}.tune.txt").read_text().splitlines()
        rec["tune_exit"] = proc.returncode
        rec["tune_said"] = [s for s in said if s.startswith(("stopped", "error", "tuned;", "validation incomplete",
                                                                "link back", "interrupted"))][-4:]
        steps = []
        if fault == "kill" and rec.get("reached"):
            rc, out = tool("restore", str(d), *conn)
            steps.append({"cmd": "restore", "exit": rc, "said": [s for s in out.splitlines() if "continues" in s]})
        stop = json.loads((d / "stopped.json").read_text()) if (d / "stopped.json").exists() else None
        left = json.loads((d / "result.json").read_text()).get("validation") or {} \
            if (d / "result.json").exists() else {}
        command = stop["command"] if stop and (fault == "kill" or proc.returncode != 0) else \
            left.get("command") if left.get("state") == "incomplete" and rec.get("reached") else None
        for attempt in range(2) if command else ():
            cmd = command.split()[1:]
            rc, out = tool(*cmd)
            steps.append({"cmd": " ".join(cmd[:2]), "exit": rc, "said": [s for s in out.splitlines() if s.startswith(
                ("stopped", "error", "tuned;", "validation incomplete", "validation stopped"))][-3:]})
            if attempt or "switch it to GUIDED" not in out:
                break
            w.conn.mav.command_long_send(1, 1, 176, 0, 1, 4, 0, 0, 0, 0, 0)  # the pilot does as told: GUIDED
            w.pump(1.0)
            steps.append({"cmd": "pilot: GUIDED", "exit": 0, "said": []})
        rec["then"] = steps
        result = json.loads((d / "result.json").read_text()) if (d / "result.json").exists() else {}
        rec["result"] = {"validation": (result.get("validation") or {}).get("state"),
                         "P_confirm": (result.get("best") or {}).get("P_confirm")}
        w.land()
    finally:
        log.close()
        if proc.poll() is None:
            proc.kill()
    w.close()
    now, armed = read_all_params(sitl)
    rec["mission_items_at_end"] = now.pop("_mission_items")
    rec["params_vs_snapshot"] = {k: list(v) for k, v in param_diff(d, now).items()}
    rec["armed_at_end"] = armed
    return rec


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", default="all", help="comma-separated case names (default: all 24: " +
                    ", ".join(cases()[:3]) + ", ...)")
    ap.add_argument("--speedup", type=float, default=10.0)
    ap.add_argument("--write", action="store_true", help="write results.md from every recorded case")
    a = ap.parse_args()
    todo = cases() if a.cases == "all" else [c for c in a.cases.split(",") if c]
    unknown = [c for c in todo if c not in cases()]
    if unknown:
        ap.error(f"unknown case(s) {unknown}; known: {', '.join(cases())}")
    OUT.mkdir(parents=True, exist_ok=True)
    runs = OUT / "runs.jsonl"
    for name in todo:
        with tempfile.TemporaryDirectory(prefix="ksbo-fault-") as tmp:
            t = time.time()
            try:
                rec = run_case(name, a.speedup, Path(tmp))
            except Exception as exc:  # noqa: BLE001 - a case the bench could not set up is recorded, not fatal
                rec = {"case": name, "reached": False, "note": f"bench failed: {type(exc).__name__}: {exc}"}
            rec["wall_s"] = round(time.time() - t)
            rec["machine"] = machine()
        with open(runs, "a") as fh:
            fh.write(json.dumps(rec) + "\n")
        print(json.dumps(rec), flush=True)
    if a.write:
        latest = {r["case"]: r for r in lines(runs)}
        records = [latest[c] for c in cases() if c in latest]
        body = (f"# Fault matrix on ArduCopter SITL with the onboard guard\n\nCommand: `python "
                f"scripts/bench_fault_matrix.py --write` (through /work/bin/heavy). Machine: "
                f"{records[-1]['machine'] if records else machine()}. {len(records)} of {len(cases())} cases.\n\n"
                + __doc__.split("\n\n")[1].replace("\n", " ") + "\n\n" + table(records))
        write_result("fault-matrix", body)
    return 0


if __name__ == "__main__":
    sys.exit(main())
