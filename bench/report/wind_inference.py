"""The wind-inference sweep's table (kind ``wind``): per set wind, what the SITL blows at the mission's height
against the inferred wind over the campaign's completed trials (each case's newest record)."""

from __future__ import annotations

from typing import Any

SHAPE = {"flat": "1 (flat)", "sqrt": "0 (sqrt, SITL default)"}


def row(r: dict[str, Any]) -> str:
    k, res = r["key"], r["result"]
    set_ = f"{k['speed']:g} from {k.get('from_deg', 45):g}°"
    if res.get("inferred_median") is None:
        return (f"| {set_} | {SHAPE[k['shape']]} | {res.get('blows_mps')} | none inferred (exit {res.get('rc')}: "
                f"{res.get('error_text', '')[:120]}) | – | – | – |")
    inside = "yes" if res["range_contains"] else "no"
    return (f"| {set_} | {SHAPE[k['shape']]} | {res['blows_mps']:.2f} | {res['inferred_min']:.2f}–"
            f"{res['inferred_max']:.2f} (median {res['inferred_median']:.2f}, {res['n_inferred']} trials) | "
            f"{res['error']:+.0%} | {inside} | {res.get('from_min_deg', '–')}–{res.get('from_max_deg', '–')}° |")


def report(recs: list[dict[str, Any]]) -> str:
    latest = {(r["key"]["shape"], r["key"]["speed"]): r for r in recs}
    order = sorted(latest, key=lambda k: (k[0] != "flat", k[1]))
    how = next((r["result"]["how"] for r in recs if r["result"].get("how")), None)
    head = ("| set (SIM_WIND_SPD) | SIM_WIND_T | blows at 10 m (m/s) | inferred per completed trial (m/s) | median vs "
            "blows | range holds it | inferred from |\n|---|---|---|---|---|---|---|")
    text = head + "\n" + "\n".join(row(latest[k]) for k in order)
    return text + (f"\n\nHow the inference was obtained (the journal's own words): {how}." if how else "")
