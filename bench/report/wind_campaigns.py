"""The wind-campaigns sweep's page below its header: per cell the flights, the cut the campaign said and the cut
re-flown by separate flights, the safety counts; the wind set against the wind inferred; the validation verdicts;
and the decision ``tune --wind`` made before takeoff against the lean the baseline's figure-8s flew."""

from __future__ import annotations

import statistics
from typing import Any

from ksbo_mav.mav.wind_source import simulated_wind

VEHICLE = {"ardupilot": "ArduCopter SITL", "px4": "PX4 SITL"}
#: The figure-8's height above home (m) in the copter profiles: where the simulator's wind is read.
FLIGHT_HEIGHT_M = 10.0


def cell(r: dict[str, Any]) -> str:
    k = r["key"]
    build = f" {k['build']}" if k.get("build") else ""
    speed = f" x{k['speedup']:g}" if k.get("speedup") else ""
    return f"{VEHICLE.get(k['vehicle'], k['vehicle'])}{build}{speed} ({k.get('label', '')})"


def _spread(xs: list[Any]) -> str:
    v = [x for x in xs or [] if x is not None]
    if not v:
        return "–"
    return f"{statistics.mean(v):.3f} ± {(max(v) - min(v)) / 2:.3f} ({len(v)})"


def _pct(x: Any) -> str:
    return "–" if x is None else f"{-100 * x:+.0f} %"


def said(res: dict[str, Any]) -> tuple[float, list[float], float] | None:
    """The cut the campaign's report says: its first flight's lap-2 RMS against its confirmation flights'."""
    first = (res.get("rms_per_flight") or [None])[0]
    confirm = [x for x in res.get("confirm_rms") or [] if x is not None]
    if not first or not confirm:
        return None
    return first, confirm, 1 - statistics.mean(confirm) / first


def campaign_row(r: dict[str, Any]) -> str:
    res, s, f = r.get("result", {}), r.get("safety", {}), r.get("flights", {})
    cut = said(res)
    said_txt = f"{cut[0]:.3f} → {statistics.mean(cut[1]):.3f} ({_pct(cut[2])})" if cut else "–"
    ref = res.get("reflown") or {}
    flights = (f"{f.get('total', '–')} + {res.get('validation_flights', 0)} validation + {f.get('reflown', 0)} "
               "re-flown")
    safety = " / ".join(str(s.get(k, "–")) for k in ("unsafe", "aborted", "crashed", "interrupted"))
    note = res.get("refly_note") or res.get("error") or ("" if r.get("status") == "ok" else r.get("status", ""))
    return (f"| {cell(r)} | {flights} | {safety} | {said_txt} | {_spread(ref.get('baseline'))} | "
            f"{_spread(ref.get('rec'))} | {_pct(res.get('cut'))} | {note.replace('|', '/')} |")


def wind_row(r: dict[str, Any]) -> str | None:
    w = r.get("result", {}).get("wind")
    if not w:
        return None
    want = w.get("set") or {}
    got = (f"{w['inferred_mps']:.1f} m/s from {w['inferred_from_deg']:g} deg" if "inferred_from_deg" in w
           else "not inferred")
    sign = {True: "yes", False: "**no**"}.get(w.get("sign_ok"), "–")
    blows = simulated_wind((r.get("key") or {}).get("sitl_params") or {}, FLIGHT_HEIGHT_M)
    at = f"{blows[0]:.1f} m/s" if blows else "–"
    return (f"| {cell(r)} | {want.get('mps', 0):g} m/s from {want.get('from_deg', 0):g} deg | {at} | {got} "
            f"({w['flights']} flights) | {sign} |")


def _mean(xs: list[Any]) -> float | None:
    v = [x for x in xs or [] if x is not None]
    return statistics.mean(v) if v else None


def validation_rows(r: dict[str, Any]) -> list[str]:
    res = r.get("result", {})
    counts = res.get("validation_by_manoeuvre") or {}
    out, judged = [], set()

    def why(m: str) -> str:
        return "; ".join(sorted({x["message"] for x in res.get("validation_not_completed", [])
                                 if x["manoeuvre"] == m and x["outcome"] == "error"}))[:200].replace("|", "/")

    for pair, ms in (res.get("verdicts") or {}).items():
        for m, j in ms.items():
            judged.add(m)
            b, c = _mean(j.get("base")), _mean(j.get("cand"))
            spread = f" (spread {j['spread']:.2g})" if j.get("spread") is not None else ""
            figs = f"{j['metric']} {b:.3g} → {c:.3g}{spread}" if b is not None and c is not None else why(m) or "–"
            ab = [j.get("base_aborted", 0), j.get("cand_aborted", 0)]
            aborts = f"{ab[0]} / {ab[1]}" if any(ab) else ""
            out.append(f"| {cell(r)} | {pair} | {m} | {counts.get(m, '–')} | {j['verdict']} | {figs} | {aborts} |")
    for m, n in counts.items():
        if m not in judged:
            out.append(f"| {cell(r)} | – | {m} | {n} | not flown | {why(m)} | |")
    return out


def preflight_row(r: dict[str, Any]) -> str | None:
    w = r.get("result", {}).get("wind_preflight")
    if not w:
        return None
    d = w["decided"]
    what = d.get("refused") or f"tilt limit {d['tilt_max_deg']:g} deg, figure-8 at {d['scale']:.0%}"
    leans = ", ".join(f"{x:.1f}" for x in w["baseline_leans_deg"]) or "–"
    return (f"| {cell(r)} | {w['drag']} | {w['predicted_full_deg']:.1f} / {w['predicted_flown_deg']:.1f} | {what} | "
            f"{leans} |")


def page(sw: Any, records: list[dict[str, Any]]) -> list[str]:
    """The page's blocks below the sweep's header (ksbo_bench.report.pages builder "wind")."""
    return [report(records)] if records else []


def report(records: list[dict[str, Any]]) -> str:
    if not records:
        return ""
    camp = [campaign_row(r) for r in records]
    wind = [x for r in records if (x := wind_row(r))]
    val = [x for r in records for x in validation_rows(r)]
    pre = [x for r in records if (x := preflight_row(r))]
    parts = [
        "## Each campaign",
        "Flights: the campaign's (baseline = 1, optimiser trials, confirmation), its validation flights and the "
        "separate re-flights. Safety: unsafe (P < 0) / aborted by the monitor (the gains) / crashed / interrupted "
        "(the vehicle, the link or this computer). Said: the campaign's first flight against its confirmation "
        "flights (lap-2 RMS, m). B, R: re-flown in turn (mean ± half range (flights)); cut: R against B.",
        "| cell | flights | unsafe / aborted / crashed / interrupted | cut said (m) | B re-flown (m) | R re-flown (m) "
        "| cut re-flown | note |\n|---|---|---|---|---|---|---|---|\n" + "\n".join(camp),
    ]
    if wind:
        parts += ["## The wind's sign", "The wind each flight inferred from its own lean and drift (median over the "
                  "campaign's flights) against the wind the cell set, as the direction it comes from; and what the "
                  f"simulator blows at the figure-8's height ({FLIGHT_HEIGHT_M:g} m, the copter profiles'), from its "
                  "own wind model (ksbo_mav.mav.wind_source.simulated_wind: ArduCopter SITL's SIM_WIND_SPD is shaped "
                  "by a square-root profile up to 60 m, 41 % of it at 10 m; SIH's wind is the same at every height).",
                  "| cell | set | blows at the flight height | inferred | same direction (±45 deg) |\n"
                  "|---|---|---|---|---|\n" + "\n".join(wind)]
    if val:
        parts += ["## Validation flights", "Baseline and candidate alternated; the verdict is decided by one figure "
                  "per manoeuvre (ksbo_mav.campaign.verdict). Aborted: baseline / candidate flights the monitor "
                  "stopped.",
                  "| cell | comparison | manoeuvre | flights | verdict | figure: baseline → candidate | aborted |\n"
                  "|---|---|---|---|---|---|---|\n" + "\n".join(val)]
    if pre:
        parts += ["## Decided before takeoff", "The lean `tune --wind` predicts for the figure-8 in the declared "
                  "wind (worst direction, the drag named), what it decided, and the peak lean of the baseline's "
                  "figure-8s as flown (the first flight and its re-flights in the campaign).",
                  "| cell | drag used | predicted peak lean, full / flown figure-8 (deg) | decided | baseline "
                  "figure-8s flown: peak lean (deg) |\n|---|---|---|---|---|\n" + "\n".join(pre)]
    return "\n\n".join(parts)
