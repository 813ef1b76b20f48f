"""The flights sweeps' pages: one table per cell (its vehicle, condition, speed-up and repeats in its caption), a
row per way it flew, a column per gain set: the figure's mean (min–max) over the repeats and its change against
the baseline flown the same way; with the baseline alone, every flight's figure and the change against the first
way. Figure-8 ways: the lap-2 3-D RMS against the pattern at each sample's own stamp (m); manoeuvres: their own
figure."""

from __future__ import annotations

import statistics
from typing import Any

from ksbo_bench.kinds.vehicles import SPEED
from ksbo_bench.report.describe import condition, spread, vehicle

#: What each manoeuvre's row reports: (metric, what it is).
FIGURES = {"steps": ("settle_s_mean", "steps: mean settling time (s)"),
           "hold": ("hold_rms_m", "LOITER hold: RMS drift (m)"),
           "auto_mission": ("xtrack_rms_m", "AUTO box: cross-track RMS (m)")}
LABELS = {"streamed": "training trial, streamed by the tuner", "onboard": "training trial flown on board (Lua)",
          "client": "separate client, no lead", "client+lead10": "separate client, 10 ms lead",
          "client-ff": "separate client, position only", "client10hz": "separate client, every 5th sample (10 Hz)"}


def figure(row: dict[str, Any]) -> float | None:
    if row["way"] in FIGURES:
        return (row.get("metrics") or {}).get(FIGURES[row["way"]][0])
    return row.get("true_rms") if row.get("true_rms") is not None else row.get("rms")


def _label(way: str) -> str:
    if way.startswith("streamed@"):
        return f"streamed at {way[9:]} Hz"
    return LABELS.get(way, FIGURES.get(way, (None, way))[1])


def _caption(r: dict[str, Any]) -> str:
    k, res = r["key"], r["result"]
    sp = k.get("speedup") or SPEED.get(k.get("vehicle", ""))
    speed = f", SITL -s {sp:g}" if sp else ""
    rate = f", ground stream at {res['rate_hz']} Hz" if res.get("rate_hz") else ""
    label = f"{k['label']}: " if k.get("label") else ""
    return (f"**{label}{vehicle(k)}, {condition(k)}{speed}{rate}, {k.get('reps', 3)} flights per cell, "
            f"{(r.get('run', {}).get('started') or '')[:10]}**")


def cell_table(r: dict[str, Any]) -> str:
    rows = r["result"]["flights"]
    ways = list(dict.fromkeys(x["way"] for x in rows))
    sets = list(dict.fromkeys(x["set"] for x in rows))
    sets = ["baseline", *[s for s in sets if s != "baseline"]] if "baseline" in sets else sets

    def vals(way: str, s: str) -> tuple[list[float], int]:
        mine = [x for x in rows if x["way"] == way and x["set"] == s]
        v = [f for x in mine if (f := figure(x)) is not None]
        return v, len(mine) - len(v)

    if len(sets) == 1:
        first = statistics.mean(vals(ways[0], sets[0])[0] or [float("nan")])
        out = ["| flown as | figure per flight | mean (min–max) | vs the first | not scored |", "|---|---|---|---|---|"]
        for w in ways:
            v, bad = vals(w, sets[0])
            rel = f"{statistics.mean(v) / first - 1:+.1%}" if v and w != ways[0] else ""
            out.append(f"| {_label(w)} | {', '.join(f'{x:.3f}' for x in v)} | {spread(v)} | {rel} | {bad} |")
        return "\n".join(out)
    head = "| flown as | " + " | ".join(sets) + " | not scored |"
    out = [head, "|" + "---|" * (len(sets) + 2)]
    for w in ways:
        base, nbad = vals(w, sets[0])
        cells = [spread(base)]
        for s in sets[1:]:
            v, bad = vals(w, s)
            nbad += bad
            rel = f" [{statistics.mean(v) / statistics.mean(base) - 1:+.0%}]" if v and base else ""
            cells.append(spread(v) + rel)
        out.append(f"| {_label(w)} | " + " | ".join(cells) + f" | {nbad} |")
    return "\n".join(out)


def report(sw, recs: list[dict[str, Any]]) -> list[str]:
    out: list[str] = []
    for r in recs:
        out += [_caption(r), cell_table(r)]
    gains = recs[0]["key"].get("gains", {}) if recs else {}
    if gains:  # the sets as the sweep declares them: the parameters each changes from the vehicle's defaults
        out.append("Gain sets: baseline = the vehicle's defaults; " + "; ".join(
            f"{name} = " + ", ".join(f"{p} {v:.4g}" for p, v in g.items()) for name, g in gains.items())
            + ". In brackets: the change against the baseline flown the same way.")
    return out
