"""The fault matrix's table (scripts/bench_fault_matrix.py): one row per case from its JSON record."""

from __future__ import annotations


def table(records: list[dict]) -> str:
    head = ("| case | gains at the fault | the vehicle after the fault (vehicle time) | trial gains flew after it | "
            "left (before any command) | tuner | then | params vs snapshot |\n|---|---|---|---|---|---|---|---|")
    rows = []
    for r in records:
        if not r.get("reached"):
            rows.append(f"| {r['case']} | – | {r.get('note', '')} | – | – | exit {r.get('tune_exit')}: "
                        f"{'; '.join(r.get('tune_said') or [])[:300]} | – | {_diff(r)} |")
            continue
        left = r["left"]
        flew = r.get("trial_gains_after_fault_s")
        flew = "0 (baseline flying)" if r["gains_at_fault"] == "baseline" else \
            ("not back in the window" if flew is None else f"{flew:.1f} s")
        then = "; ".join(f"`{s['cmd']}` exit {s['exit']}" for s in r.get("then") or []) or "–"
        rows.append(f"| {r['case']} | {r['gains_at_fault']} | {'; '.join(r['vehicle'])[:400]} | {flew} | "
                    f"{left['mode']} {'armed' if left['armed'] else 'disarmed'}, {left['gains']} | exit "
                    f"{r['tune_exit']}: {'; '.join(r['tune_said'])[:300]} | {then}; validation "
                    f"{r['result'].get('validation')} | {_diff(r)} |")
    return head + "\n" + "\n".join(rows)


def _diff(r: dict) -> str:
    diff = r.get("params_vs_snapshot")
    if diff is None:
        return "not read"
    mission = r.get("mission_items_at_end")
    text = "all equal" if not diff else f"{len(diff)} differ: " + ", ".join(sorted(diff)[:6])
    return text + ("" if mission is None else f"; stored mission {mission} item(s)")
