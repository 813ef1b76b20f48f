"""The fault matrix's pages (sweep ``fault-matrix``, kind ``fault``): one row per case from its newest record, a
headline table (what the vehicle did, what continued it, the parameters against the snapshot) and a detailed one
(the vehicle's events after the fault, the tuner's last words)."""

from __future__ import annotations

from typing import Any

from ksbo_bench.kinds.fault_moments import FAULTS, PHASES


def newest(recs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Each case's newest record, in the matrix's order (fault, phase, with the pilot first)."""
    latest = {(r["key"]["fault"], r["key"]["phase"], r["key"]["pilot"]): r for r in recs}
    order = [(f, p, who) for f in FAULTS for p in PHASES for who in (True, False)]
    return [latest[k] for k in order if k in latest]


def _left(res: dict[str, Any]) -> str:
    left = res.get("left") or {}
    if not left:
        return "–"
    return f"{left['mode']} {'armed' if left['armed'] else 'disarmed'}, {left['gains']}"


def _vehicle(res: dict[str, Any]) -> str:
    """The first mode change after the fault, and how the vehicle ended in the window."""
    events = res.get("vehicle") or []
    modes = [e for e in events if e.split(" s ", 1)[-1].split(" ")[0].isupper() and not e.split(" s ", 1)[-1]
             .startswith("KSG")]
    guard = next((e.split(" s ")[0] + " s" for e in events if "guard tripped" in e), None)
    parts = ([f"guard tripped {guard}"] if guard else []) + [m.replace(" s ", " s: ") for m in modes[:3]]
    return "; ".join(parts) or "no change"


def _flew(res: dict[str, Any]) -> str:
    if res.get("gains_at_fault") == "baseline":
        return "– (baseline on)"
    flew, wall = res.get("trial_gains_after_fault_s"), res.get("trial_gains_after_fault_wall_s")
    if flew is None:
        return "not back in the window"
    return f"{flew:.1f} s" + ("" if wall is None else f" ({wall:.1f} s wall)")


def _cmd(cmd: str) -> str:
    """A command without its campaign folder (a temporary path)."""
    return " ".join(w for w in cmd.split() if not w.startswith("/"))


def _then(res: dict[str, Any]) -> str:
    steps = [f"`{_cmd(s['cmd'])}` {s['exit']}" for s in res.get("then") or [] if not s["cmd"].startswith("pilot")]
    pilot = any(s["cmd"].startswith("pilot") for s in res.get("then") or [])
    return (", ".join(steps) or "– (went on by itself)") + (" (pilot: GUIDED)" if pilot else "")


def _params(res: dict[str, Any]) -> str:
    diff = res.get("params_vs_snapshot")
    if diff is None:
        return "not read"
    text = "all equal" if not diff else f"{len(diff)} differ: " + ", ".join(sorted(diff)[:4])
    return text + f"; mission {res.get('mission_items_at_end')} item(s)"


def _cell(r: dict[str, Any] | None) -> str:
    """One case in the matrix: the tuner's exit, what continued it, the mode left, the parameters."""
    if r is None:
        return "not flown yet"
    res = r["result"]
    diff = res.get("params_vs_snapshot")
    params = "not read" if diff is None else "equal" if not diff else f"{len(diff)} differ"
    if not res.get("reached"):
        return f"not reached: {res.get('note', '')}; exit {res.get('tune_exit')}; params {params}"
    left = res.get("left") or {}
    where = f"{left.get('mode')} {'armed' if left.get('armed') else 'landed'}" if left else "?"
    return f"exit {res.get('tune_exit')} → {_then(res)}; left {where}; params {params}"


def matrix(recs: list[dict[str, Any]]) -> str:
    """The matrix itself: a row per phase, a column per fault and pilot (each case's newest record)."""
    latest = {(r["key"]["fault"], r["key"]["phase"], r["key"]["pilot"]): r for r in recs}
    cols = [(f, who) for f in FAULTS for who in (True, False)]
    head = "| phase | " + " | ".join(f"{f}, {'pilot' if who else 'no pilot'}" for f, who in cols) + " |"
    rows = [f"| {p} | " + " | ".join(_cell(latest.get((f, p, who))) for f, who in cols) + " |" for p in PHASES]
    return "\n".join([head, "|---" * (len(cols) + 1) + "|", *rows])


def table(recs: list[dict[str, Any]]) -> str:
    head = ("| case | at the fault | the vehicle after it (vehicle time) | trial gains on after it (vehicle time) "
            "| left | tuner exit | then (exit) | validation | params vs snapshot |\n"
            "|---|---|---|---|---|---|---|---|---|")
    rows = []
    for r in newest(recs):
        res = r["result"]
        if not res.get("reached"):
            rows.append(f"| {res['case']} | – | {res.get('note', '')} | – | – | {res.get('tune_exit')} | "
                        f"{_then(res)} | {res['result'].get('validation') or '–'} | {_params(res)} |")
            continue
        rows.append(f"| {res['case']} | {res['mode_at_fault']}, {res['gains_at_fault']} | {_vehicle(res)} | "
                    f"{_flew(res)} | {_left(res)} | {res['tune_exit']} | {_then(res)} | "
                    f"{res['result'].get('validation') or '–'} | {_params(res)} |")
    return head + "\n" + "\n".join(rows)


def details(recs: list[dict[str, Any]]) -> str:
    """Per case: every event after the fault and the tuner's last lines."""
    out = ["## Each case in full"]
    for r in newest(recs):
        res = r["result"]
        said = " / ".join(s.replace("|", "/") for s in res.get("tune_said") or []) or "–"
        then = "; ".join(f"`{_cmd(s['cmd'])}` exit {s['exit']}: " + " / ".join(s["said"])
                         for s in res.get("then") or [])
        load = r["timing"].get("load_1min")
        out.append(f"**{res['case']}** ({r['run']['started'][:16].replace('T', ' ')} UTC, {r['timing'].get('case_s')}"
                   f" s{'' if load is None else f', load {load}'}). "
                   + (f"Setup: {res['setup']}. " if res.get("setup") else "")
                   + f"After the fault: {'; '.join(res.get('vehicle') or []) or res.get('note', '–')}. "
                   f"Tuner: exit {res.get('tune_exit')}: {said}. Then: {then or '–'}. "
                   f"Flights: {r['flights'].get('total')} ({r['flights'].get('validation')} validation); "
                   f"interrupted {r['safety'].get('interrupted')}, crashed {r['safety'].get('crashed')}.")
    return "\n\n".join(out)


def report(recs: list[dict[str, Any]]) -> str:
    return "\n\n".join([matrix(recs), "**Each case** (its newest record; history and what was tried: "
                        "[benchmarks/notes/stops.md](../notes/stops.md))", table(recs), details(recs)])
