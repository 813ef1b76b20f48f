"""One case of the fault matrix (ksbo_bench.kinds.fault), flown on a fresh ArduCopter SITL: the tuner behind the
link emulator, a second connection the tuner does not use (ksbo_sim.vehicle_watch), the bench pilot where the case
has one; the fault at the phase's moment; then what continues it, and every parameter against the snapshot."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from ksbo_bench.cell_errors import InfraError
from ksbo_bench.kinds.fault_moments import (CUT_S, OBSERVE_S, VALIDATION_PHASES, gains_text, lines, profile, reached,
                                            recommend_other)

#: What a tuner's console lines worth keeping begin with.
SAID = ("stopped", "error", "tuned;", "validation incomplete", "validation stopped", "link back", "interrupted")


def tool(*args: str, timeout: float = 900) -> tuple[int, str]:
    r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", *args], capture_output=True, text=True, timeout=timeout)
    return r.returncode, r.stdout + r.stderr


def said(text: str, n: int = 4) -> list[str]:
    return [s for s in text.splitlines() if s.startswith(SAID)][-n:]


def fly_case(key: dict[str, Any], sitl, tmp: Path, stoppers: list) -> dict[str, Any]:
    """The case's record (ksbo_bench.kinds.fault documents it); what it starts is appended to ``stoppers``."""
    from ksbo_sim.bench_pilot import PilotProcess
    from ksbo_sim.errors import SimStartError
    from ksbo_sim.linkproc import LinkEmulator
    from ksbo_sim.process import free_udp_port
    from ksbo_sim.vehicle_watch import VehicleWatch

    fault, phase = key["fault"], key["phase"]
    rec: dict[str, Any] = {}
    gport = free_udp_port()
    try:
        emu = LinkEmulator(f"tcp:127.0.0.1:{sitl.tcp_port}", f"udp:127.0.0.1:{gport}", startup_timeout=120)
        stoppers.append(emu.stop)
        if key["pilot"]:
            stoppers.append(PilotProcess(f"tcp:127.0.0.1:{sitl.tcp_ports[2]}", startup_timeout=120).stop)
        w = VehicleWatch(f"tcp:127.0.0.1:{sitl.tcp_ports[1]}", position_hz=4.0, reconnect=True, wait_s=30.0)
    except (SimStartError, TimeoutError, OSError) as exc:
        raise InfraError(f"the case's processes did not start: {exc}") from exc
    stoppers.append(w.close)
    conn = ["--udp", f"127.0.0.1:{gport}"]
    d = tmp / "campaign"
    tune = ["tune", str(d), *conn, "--profile", str(profile(tmp)), "--budget", "2", "--confirm", "1", "--prior",
            "none", "--method", "random", "--seed", str(key.get("seed", 0))]
    if phase in VALIDATION_PHASES:  # the validation flights of a recommendation that is not the baseline
        rc, out = tool(*tune, "--validation", "off")
        if not (d / "result.json").is_file():
            raise InfraError(f"the setup tune (--validation off) ended with exit {rc}: {' | '.join(said(out))}")
        rec["setup"] = f"tune --validation off: exit {rc}; recommendation set to {recommend_other(d)}"
        cmd = ["validate", str(d), *conn]
    else:  # the tune's phases: its continuation is the tune's own (validation: the hold and auto cases)
        cmd = [*tune, "--validation", "off"]
    log_path = tmp / "tuner.txt"
    with open(log_path, "w") as log:
        proc = subprocess.Popen([sys.executable, "-m", "ksbo_mav.cli", *cmd], stdout=log, stderr=subprocess.STDOUT,
                                text=True)
    stoppers.append(lambda: proc.kill() if proc.poll() is None else None)
    t_start = time.monotonic()
    started: dict = {}
    moment: bool | None = False
    while time.monotonic() - t_start < 900 and proc.poll() is None:
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
        rec.update(_strike(fault, proc, emu, w, sorted(base), base))
        proc.wait(900)
    rec["tune_exit"] = proc.returncode
    rec["tune_said"] = said(log_path.read_text())
    rec["then"] = _continue(fault, rec, d, conn, proc.returncode, w)
    result = json.loads((d / "result.json").read_text()) if (d / "result.json").exists() else {}
    rec["result"] = {"validation": (result.get("validation") or {}).get("state"),
                     "P_confirm": (result.get("best") or {}).get("P_confirm")}
    rec["landed_by_bench"] = w.land()
    rec["journal"] = lines(d / "journal.jsonl")
    rec["validation_flights"] = len(lines(d / "validation.jsonl"))
    return rec


def _strike(fault: str, proc, emu, w, names: list[str], base: dict[str, float]) -> dict[str, Any]:
    """The fault, and what the vehicle did in the window after it (the cut's 8 s, or 12 s after a kill, wall)."""
    out: dict[str, Any] = {}
    t0_ms, t0 = w.vehicle_ms, time.monotonic()
    out["gains_at_fault"] = gains_text(w.params(names, tries=1), base)
    out["mode_at_fault"], out["height_at_fault_m"] = w.mode_name(w.mode), w.height
    w.events.clear()
    if fault == "kill":
        proc.kill()
    else:
        emu.cut()
    back_ms = back_wall = None
    while time.monotonic() - t0 < (CUT_S if fault == "cut" else OBSERVE_S):
        now = w.params(names, tries=1)
        if back_ms is None and now and gains_text(now, base) == "baseline":
            back_ms, back_wall = w.vehicle_ms - t0_ms, time.monotonic() - t0
        w.pump(0.3)
    # vehicle time (the SITL's clock, 10x), and wall time: the guard counts the tuner's silence in vehicle time
    # scaled to the tuner's wall-clock timeout (on a real vehicle both are the same)
    out["trial_gains_after_fault_s"] = None if back_ms is None else round(back_ms / 1000.0, 1)
    out["trial_gains_after_fault_wall_s"] = None if back_wall is None else round(back_wall, 1)
    out["vehicle"] = [f"{(t - t0_ms) / 1000.0:+.1f} s {what}" for t, what in w.events if t >= t0_ms]
    out["left"] = {"mode": w.mode_name(w.mode), "armed": w.armed, "height_m": w.height,
                   "gains": gains_text(w.params(names), base)}
    if fault == "cut":
        emu.reconnect()
    return out


def _continue(fault: str, rec: dict[str, Any], d: Path, conn: list[str], tune_exit: int | None, w
              ) -> list[dict[str, Any]]:
    """After a kill: ``restore``, then the command it names; after a cut that stopped the tuner: the command its
    stop printed (an incomplete validation: the one result.json names). The bench pilot switches to GUIDED when a
    command asks for it."""
    steps: list[dict[str, Any]] = []
    if fault == "kill" and rec.get("reached"):
        rc, out = tool("restore", str(d), *conn)
        steps.append({"cmd": "restore", "exit": rc, "said": [s for s in out.splitlines() if "continues" in s]})
    stop = json.loads((d / "stopped.json").read_text()) if (d / "stopped.json").exists() else None
    left = (json.loads((d / "result.json").read_text()).get("validation") or {}) \
        if (d / "result.json").exists() else {}
    command = stop["command"] if stop and (fault == "kill" or tune_exit != 0) else \
        left.get("command") if left.get("state") == "incomplete" and rec.get("reached") else None
    for attempt in range(2) if command else ():
        args = command.split()[1:]
        rc, out = tool(*args)
        steps.append({"cmd": " ".join(args[:2]), "exit": rc, "said": said(out, 3)})
        if attempt or "switch it to GUIDED" not in out:
            break
        w.set_mode(4)  # the pilot does as told: GUIDED
        w.pump(1.0)
        steps.append({"cmd": "pilot: GUIDED", "exit": 0, "said": []})
    return steps
