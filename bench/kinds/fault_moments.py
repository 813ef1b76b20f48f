"""The fault matrix's campaign and its moments (ksbo_bench.kinds.fault): the short campaign a case flies, when the
case's phase has come, and the gains a second connection reads."""

from __future__ import annotations

import json
import time
from pathlib import Path

#: The faults: the link cut, the tuner killed (SIGKILL).
FAULTS = ("cut", "kill")
#: The link cut's length and the window watched after a kill (wall seconds; 80 and 120 s of vehicle time at 10x).
CUT_S, OBSERVE_S = 8.0, 12.0
#: The phases a fault strikes in: the tune's (takeoff, mid-trial, between trials, the confirmation flight) and the
#: validation's (its LOITER hold, its AUTO mission).
PHASES = ("takeoff", "mid-trial", "between-trials", "confirmation", "hold", "auto")
VALIDATION_PHASES = ("hold", "auto")
#: The copter profile with small validation manoeuvres flown twice with each gain set (quick halves them again).
SMALL_VALIDATION = """
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
ROOT = Path(__file__).resolve().parents[2]
#: ArduCopter custom modes the moments look for.
AUTO, LOITER = 3, 5


def profile(tmp: Path) -> Path:
    text = (ROOT / "params" / "ardupilot-copter.toml").read_text()
    p = tmp / "small-validation.toml"
    p.write_text(text[:text.index("[validation]")] + SMALL_VALIDATION)
    return p


def lines(path: Path) -> list[dict]:
    return [json.loads(x) for x in path.read_text().splitlines() if x.strip()] if path.exists() else []


def reached(phase: str, d: Path, w, started: dict) -> bool | None:
    """Whether the fault's moment has come (None: it never will: the hold refused without a pilot). ``w`` is the
    second connection (ksbo_sim.vehicle_watch.VehicleWatch, with GLOBAL_POSITION_INT); ``started`` this case's
    memory between calls."""
    journal, tlogs = lines(d / "journal.jsonl"), sorted((d / "trials").glob("trial_*.tlog"))
    now = time.monotonic()
    if phase == "takeoff":
        return bool(w.armed and w.height is not None and 1.0 < w.height < 7.0 and not tlogs)
    if phase == "between-trials":
        return len(journal) >= 2
    if phase in ("mid-trial", "confirmation"):
        # trial 1 an optimiser trial, trial 2 the confirmation: its tlog open and the guard armed for it, then the
        # flight's gains read on the vehicle (the tuner writes them just after arming the guard) and 0.5 s of wall
        # time (5 s of vehicle time) more; gains that stay the baseline's (a confirmation of the baseline) are
        # struck 2 s after the guard armed
        want = 1 if phase == "mid-trial" else 2
        if "tlog" not in started and len(journal) >= want and len(tlogs) > want:
            started["tlog"] = w.vehicle_ms
        if "tlog" in started and "at" not in started and w.first_alive(1.0, started["tlog"]) is not None:
            started["at"] = now
        if "at" in started and "gains" not in started:
            base = json.loads((d / "campaign.json").read_text())["baseline"]
            if gains_text(w.params(sorted(base), tries=1, wait_s=0.3), base).startswith("trial"):
                started["gains"] = now
        return ("gains" in started and now - started["gains"] >= 0.5) or ("at" in started and now - started["at"]
                                                                         >= 2.0)
    flights = lines(d / "validation.jsonl")
    if phase == "hold":
        if any(f["manoeuvre"] == "hold" and f["outcome"] == "error" for f in flights):
            return None
        if w.mode == LOITER and (d / "validation").exists() and "at" not in started:
            started["at"] = now
    if phase == "auto" and w.mode == AUTO and "at" not in started:
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


def gains_text(now: dict[str, float], base: dict[str, float]) -> str:
    """"baseline", "trial (k of n off the baseline)" or "not read (k of n answered)"."""
    if len(now) < len(base):
        return f"not read ({len(now)} of {len(base)} answered)"
    same = sum(abs(now[n] - base[n]) <= 1e-6 * max(1.0, abs(base[n])) for n in base if n in now)
    return "baseline" if same == len(base) else f"trial ({len(base) - same} of {len(base)} off the baseline)"
