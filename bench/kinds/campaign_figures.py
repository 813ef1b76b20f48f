"""The figures of a campaign cell computed from its journal, its re-flights and its console: the best flown gains
each time they changed, the cut and the share of the reference's cut, the flights to 90 %, the flight at which a
warm start reached the earlier result, and what the tool said (drift, warm start, parameters, link rate)."""

from __future__ import annotations

import re
from typing import Any

from ksbo_bench.kinds.independent_refly import mean


def best_so_far(entries: list[dict], names: list[str]) -> list[tuple[int, dict[str, float], float]]:
    """[(flight number, gains, its flown lap RMS)] each time the best flown gains changed (baseline excluded)."""
    out: list[tuple[int, dict[str, float], float]] = []
    best = None
    for k, e in enumerate(entries):
        if k == 0 or e["kind"] == "baseline" or e["outcome"] != "ok" or not e.get("rms"):
            continue
        if best is None or e["rms"] < best:
            best = e["rms"]
            out.append((k + 1, dict(zip(names, e["x"])), e["rms"]))
    return out


def refly_figures(result: dict[str, Any], cands: list, n_flights: int) -> None:
    """cut, and against a reference ("long"): the target, the share of its cut, the flights to 90 % of it."""
    m = {k: mean(v) for k, v in result["reflown"].items()}
    if m.get("rec") is None or not m.get("baseline"):
        return
    result["cut"] = 1 - m["rec"] / m["baseline"]
    if m.get("long") is not None:
        target = m["baseline"] - 0.9 * (m["baseline"] - m["long"])
        result["target_rms"] = target
        hits = [k for k, _, _ in cands if m.get(f"f{k}") is not None and m[f"f{k}"] <= target]
        result["flights_to_90"] = min(hits) if hits else (n_flights if m["rec"] <= target else None)
        if m["baseline"] != m["long"]:
            result["share_of_long"] = (m["baseline"] - m["rec"]) / (m["baseline"] - m["long"])


def reached_at(rms_per_flight: list[float | None], earlier: list[float | None]) -> int | None:
    """The first flight after the baseline (flight 1) whose lap RMS is within the re-flight spread of the earlier
    recommendation's re-flights (at least 5 mm above their mean): where a warm start got back to the earlier result."""
    e = [x for x in earlier if x is not None]
    if not e:
        return None
    target = sum(e) / len(e) + max(max(e) - min(e), 0.005)
    return next((i + 1 for i, x in enumerate(rms_per_flight) if x is not None and i > 0 and x <= target), None)


_PARAMS = re.compile(r"parameters: (\d+) of (\d+) downloaded in ([\d.]+) s \(([^)]*)\)")
_RATE = re.compile(r"link: flying at (\d+) Hz")


def console_figures(stderr: str) -> dict[str, Any]:
    """What the campaign's console said that a benchmark reports (only what it said): the drift verdict, the warm
    start's comparison, the parameter download, the mission rate the link check chose, how often the link was
    lost, the stop."""
    text = " ".join(stderr.split())  # the console wraps its lines
    out: dict[str, Any] = {}
    if "drift: " in text:
        out["drift"] = text[text.index("drift: "):].split("; continuing")[0].split(": check")[0]
    i = text.find("warm start: the earlier recommendation")
    if i >= 0:
        out["warm_start"] = text[i:text.find(" opt trial", i)] if text.find(" opt trial", i) > 0 else text[i:i + 300]
    if m := _PARAMS.search(text):
        out["params"] = list(m.groups())
    if m := _RATE.search(text):
        out["rate_hz"] = int(m.group(1))
    if n := text.count("link lost"):
        out["link_lost"] = n
    stops = [ln for ln in stderr.splitlines() if ln.startswith("stopped: ")]
    if stops:
        out["stopped"] = stops[-1][9:][:300]
    return out
