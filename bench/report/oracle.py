"""The oracle sweeps' pages: a gain grid flown on one vehicle per condition (kind ``flights``), one table per cell,
a row per gain set: its mean lap-2 RMS, roughness and motor oscillation (where measured) over the repeats, the
largest tilt, the score with the
profile's smoothness term and with tracking alone (both against the baseline flown in the same cell), and the
oracle, the best set by the score with the smoothness term, said with what limited it."""

from __future__ import annotations

import statistics
from functools import cache
from typing import Any

from ksbo_bench.report.describe import condition, vehicle
from ksbo_mav.smoothness import FLOOR_DPS, smooth_penalty

@cache
def _constants() -> tuple[float, float, float]:
    """The copter profiles' score constants ([score] unsafe_rms_ratio, smooth_weight, rough_band), from the profile
    itself (ArduPilot's and PX4's set the same)."""
    from ksbo_mav.profiles import load_profile

    spec = load_profile("ardupilot-copter").score_spec
    return float(spec.unsafe_rms_ratio), float(spec.smooth_weight), float(spec.rough_band)


def _fmt(v: float | None, spec: str) -> str:
    """``v`` formatted, or a dash where it is missing (None, or NaN: a mean of nothing)."""
    return "–" if v is None or v != v else format(v, spec)


def _mean(rows: list[dict[str, Any]], field: str) -> float | None:
    v = [r[field] for r in rows if r.get(field) is not None]
    return statistics.mean(v) if v else None


def _score(rms: float, rms0: float, rough: float | None, rough0: float | None) -> float:
    """The copter profiles' score of a lap RMS and roughness against the baseline's (ksbo_mav.mav.mission)."""
    ratio, weight, band = _constants()
    return 1.0 - (rms / rms0 + smooth_penalty(rough, rough0, weight, band)) / ratio


#: The validation manoeuvres a cell may fly beside the figure-8, with the figure each is judged by
#: (ksbo_mav.mav.validation.manoeuvre_spec.HEADLINE) and its heading.
MANOEUVRES = {"hold": ("hold_rms_m", "hold RMS (m)", ".3f"), "steps": ("settle_s_mean", "step settling (s)", ".2f"),
              "auto_mission": ("xtrack_rms_m", "AUTO cross-track RMS (m)", ".3f")}


def _manoeuvres(mine: list[dict[str, Any]]) -> dict[str, float | None]:
    """{manoeuvre: mean of its headline figure over the flights that ended ok} for the manoeuvres flown."""
    out = {}
    for way, (figure, _, _) in MANOEUVRES.items():
        flown = [r for r in mine if r.get("way") == way]
        if flown:
            out[way] = _mean([r.get("metrics") or {} for r in flown if r.get("outcome") == "ok"], figure)
    return out


def summary(rec: dict[str, Any]) -> list[dict[str, Any]]:
    """Per gain set: {set, gains, rms, rough, motor, tilt, n, bad, P, P_track, manoeuvres}; P from the figure-8
    flights' means against the baseline's; manoeuvres: :func:`_manoeuvres`."""
    res = rec["result"]
    all_rows = res["flights"]
    rows = [r for r in all_rows if r.get("way") not in MANOEUVRES]  # the figure-8 flights
    base = [r for r in rows if r["set"] == "baseline" and r.get("outcome") == "ok"]
    rms0, rough0 = _mean(base, "rms"), _mean(base, "rough")
    out = []
    for name, gains in res["sets"].items():
        mine = [r for r in rows if r["set"] == name]
        ok = [r for r in mine if r.get("outcome") == "ok" and r.get("rms") is not None]
        rms, rough, motor = _mean(ok, "rms"), _mean(ok, "rough"), _mean(ok, "motor")
        tilt = max((r["tilt_max"] for r in ok if r.get("tilt_max") is not None), default=None)
        P = P_track = None
        if rms is not None and rms0 and len(ok) == len(mine):  # a set with an aborted flight is no candidate
            P_track, P = _score(rms, rms0, None, None), _score(rms, rms0, rough, rough0)
        out.append({"set": name, "gains": gains, "rms": rms, "rough": rough, "motor": motor, "tilt": tilt,
                    "n": len(mine), "bad": len(mine) - len(ok), "P": P, "P_track": P_track,
                    "manoeuvres": _manoeuvres([r for r in all_rows if r["set"] == name])})
    return out


def _limit(best: dict[str, Any], track: dict[str, Any], ranges: dict[str, tuple[float, float]],
           axes: list[str], rows: list[dict[str, Any]]) -> str:
    """What kept the oracle where it is: safety (sets further along every grid gain aborted), smoothness (tracking
    alone would go elsewhere), a grid gain at the end of its documented range."""
    edges = [f"{p} at its documented {'upper' if v >= hi else 'lower'} end {v:g}"
             for p, (lo, hi) in ranges.items() if p in axes and (v := best["gains"].get(p)) is not None
             and not lo < v < hi]
    said = []
    beyond = [r["set"] for r in rows if r["bad"] and r["set"] != best["set"]
              and all(r["gains"].get(p, 0.0) >= best["gains"].get(p, 0.0) for p in axes)]
    if beyond:
        said.append(f"safety: {', '.join(beyond)}, beyond it, did not end ok (aborted by the monitor)")
    if track["set"] != best["set"]:
        said.append(f"smoothness: tracking alone would take {track['set']} (lap RMS {track['rms']:.3f} m, roughness "
                    f"{track['rough']:.2f} deg/s)")
    if edges:
        said.append("the range: " + ", ".join(edges))
    return "; ".join(said) or "neither the range nor smoothness: an inner optimum of the grid"


def cell(rec: dict[str, Any], ranges: dict[str, tuple[float, float]]) -> list[str]:
    k = rec["key"]
    rows = summary(rec)
    axes = [p for p in ranges if any(p in r["gains"] for r in rows)]
    motors = any(r["motor"] is not None for r in rows)  # SERVO_OUTPUT_RAW streamed in the cell
    flown = [w for w in MANOEUVRES if any(w in r["manoeuvres"] for r in rows)]
    head = ("| set | " + " | ".join(axes) + " | flights | lap RMS (m) | roughness (deg/s) | "
            + ("motor oscillation (µs) | " if motors else "") + "largest tilt (deg) | "
            + "".join(f"{MANOEUVRES[w][1]} | " for w in flown) + "P, tracking alone | P (with smoothness) |")
    caption = (f"**{vehicle(k)}, {k.get('condition') or condition(k)}, {k.get('reps', 3)} flight(s) per set, "
               f"{(rec.get('run', {}).get('started') or '')[:10]}**")
    out = [head, "|" + "---|" * (len(axes) + 6 + motors + len(flown))]
    scored = [r for r in rows if r["P"] is not None]
    best = max(scored, key=lambda r: r["P"]) if scored else None
    for r in sorted(rows, key=lambda r: tuple(r["gains"].get(p, 0.0) for p in axes)):
        mark = "**" if best is not None and r["set"] == best["set"] else ""
        bad = f" ({r['bad']} not ok)" if r["bad"] else ""
        out.append(f"| {mark}{r['set']}{mark} | " + " | ".join(_fmt(r["gains"].get(p), "g") for p in axes)
                   + f" | {r['n']}{bad} | {_fmt(r['rms'], '.3f')} | {_fmt(r['rough'], '.2f')} | "
                   + (f"{_fmt(r['motor'], '.1f')} | " if motors else "")
                   + f"{_fmt(r['tilt'], '.1f')} | "
                   + "".join(f"{_fmt(r['manoeuvres'].get(w), MANOEUVRES[w][2])} | " for w in flown)
                   + f"{_fmt(r['P_track'], '.3f')} | {mark}{_fmt(r['P'], '.3f')}{mark} |")
    return [caption, "\n".join(out)]


def _headline(rec: dict[str, Any], ranges: dict[str, tuple[float, float]]) -> str:
    """One row of the summary: the cell's condition, baseline, oracle (by the score), best by tracking alone."""
    rows = summary(rec)
    scored = [r for r in rows if r["P"] is not None]
    if not scored:
        return f"| {rec['key'].get('condition')} | – | – | – | – | – |"
    best, track = max(scored, key=lambda r: r["P"]), max(scored, key=lambda r: r["P_track"])
    base = next(r for r in rows if r["set"] == "baseline")
    axes = sorted({p for r in rows for p, v in r["gains"].items() if v != base["gains"].get(p)})
    shown = lambda r: f"{r['set']}: {r['rms']:.3f} m, {r['rough']:.2f} deg/s"  # noqa: E731
    return (f"| {rec['key'].get('condition')} | {shown(base)} | **{shown(best)}**, P {best['P']:.3f} | "
            f"{shown(track)}, P {track['P']:.3f} | {len(rows)} sets, {len(rec['result']['flights'])} flights | "
            f"{_limit(best, track, ranges, axes, rows)} |")


def report(sw, recs: list[dict[str, Any]]) -> list[str]:
    from ksbo_bench.kinds.flights import _profile
    from ksbo_mav.profiles import load_profile

    cells: list[str] = []
    head = ["The oracle in each condition: the best set by the score with the smoothness term (lap RMS, roughness)",
            "| condition | baseline | oracle | best by tracking alone | flown | what limited the oracle |\n"
            "|---|---|---|---|---|---|"]
    for rec in recs:
        prof = load_profile(_profile(rec["key"]))
        ranges = {}
        for g, (lo, hi) in zip(prof.gains, prof.bounds):  # by either generation's name (ArduPilot)
            for name in (g.name, g.extra.get("legacy_name")):
                if name:
                    ranges[name] = (float(lo), float(hi))
        head[1] += "\n" + _headline(rec, ranges)
        cells += cell(rec, ranges)
    out = [*head, *cells]
    ratio, weight, band = _constants()
    out.append(f"P from each set's mean lap RMS and roughness against the baseline's in the same cell: P = 1 - (RMS / "
               f"RMS_base + {weight:g} max(0, rough - rough_base - {band:g} r) / r) / {ratio:g}, r = max(rough_base, "
               f"{FLOOR_DPS:g}) (the copter "
               "profiles' score); a set with a flight that did not end ok is no candidate.")
    return out


def _oracle_P(condition_name: str) -> tuple[str, float] | None:
    """(set, P) of the oracle sweep's cell in ``condition_name``, from its store (None when not flown)."""
    from ksbo_bench import sweep as sweeps
    from ksbo_bench.store import Store

    sw = next((s for s in sweeps.all_sweeps() if s.name == "oracle-copter3d"), None)
    recs = [r for r in Store(sw.store).records() if r["key"].get("condition") == condition_name] if sw else []
    scored = [r for r in summary(recs[-1]) if r["P"] is not None] if recs else []
    best = max(scored, key=lambda r: r["P"]) if scored else None
    return (best["set"], best["P"]) if best else None


def _refly_means(rec: dict[str, Any]) -> tuple[dict[str, float], dict[str, float], dict[str, float]]:
    """({role: mean re-flown lap RMS}, {role: mean re-flown roughness}, {role: mean re-flown motor oscillation})
    of a campaign record."""
    res = rec["result"]

    def means(d: dict[str, list]) -> dict[str, float]:
        return {k: statistics.mean([x for x in v if x is not None] or [float("nan")]) for k, v in d.items()}

    return means(res.get("reflown", {})), means(res.get("reflown_rough", {})), means(res.get("reflown_motor", {}))


def _where(rec: dict[str, Any]) -> tuple:
    """The vehicle and condition a campaign record flew in (its long campaign is the one with the same)."""
    k = rec["key"]
    return k.get("vehicle"), k.get("condition", ""), repr(sorted((k.get("sitl_params") or {}).items()))


def one_pack(sw, recs: list[dict[str, Any]]) -> list[str]:
    """The default campaign's cells against the long campaign flown on the same vehicle in the same condition (label
    long, the oracle by search): flights, safety, the re-flown baseline and recommendation (lap RMS, roughness,
    motor oscillation where measured), the
    recommendation's cut and its share of the oracle's (the reference the cell re-flew beside it: the long
    campaign's recommendation, or a grid oracle's best set), its score, and the grid oracle's P where one was
    flown (oracle-copter3d)."""
    motors = any(r["result"].get("reflown_motor") for r in recs)
    out = ["| vehicle | campaign | seed | flights | aborted | crashed | P < 0 | baseline RMS (m) / roughness | "
           "recommendation RMS (m) / roughness | " + ("motor oscillation, baseline / recommendation (µs) | " * motors)
           + "cut | share of the oracle's cut | P |", "|" + "---|" * (12 + motors)]
    longs = {_where(r): r for r in recs if r["key"].get("label") == "long"}
    grid = None
    for rec in sorted(recs, key=lambda r: (_where(r), r["key"].get("label") == "long", r["key"].get("seed", 0))):
        saf = rec.get("safety", {})
        m, g, mo = _refly_means(rec)
        P = _score(m["rec"], m["baseline"], g.get("rec"), g.get("baseline")) if "rec" in m else None
        cut = 1.0 - m["rec"] / m["baseline"] if "rec" in m else None
        ref = longs.get(_where(rec))
        share = "–"
        if rec["result"].get("share_of_long") is not None:  # the reference's gains re-flown beside these
            which = "grid" if "gains" in (rec["key"].get("reference") or {}) else "long"
            share = f"{rec['result']['share_of_long']:.0%} ({which})"
        elif ref is not None and ref is not rec and cut is not None:
            lm = _refly_means(ref)[0]
            share = f"{cut / (1.0 - lm['rec'] / lm['baseline']):.0%} (long)"
        grid = grid or (_oracle_P(rec["key"]["condition"]) if rec["key"].get("condition") else None)
        out.append(f"| {vehicle(rec['key'])} {condition(rec['key'])} | {rec['key'].get('label', 'default')} | "
                   f"{rec['key'].get('seed')} | {rec['flights']['total']} | {saf.get('aborted')} | "
                   f"{saf.get('crashed')} | {saf.get('unsafe')} | {m['baseline']:.3f} / {g.get('baseline', 0):.2f} | "
                   f"{m['rec']:.3f} / {g.get('rec', 0):.2f} | "
                   + (f"{_fmt(mo.get('baseline'), '.1f')} / {_fmt(mo.get('rec'), '.1f')} | " * motors)
                   + f"{_fmt(cut, '.0%')} | {share} | {_fmt(P, '.3f')} |")
    out = ["\n".join(out)]
    out.append("Cut: 1 − the recommendation's mean re-flown lap RMS / the baseline's, both re-flown in turn on the "
               "vehicle the campaign left hovering; share: that cut over the oracle's, re-flown in turn with the two: "
               "(grid) the oracle grid's best set the cell names as its reference, (long) the long campaign's "
               "recommendation (label long, the same vehicle and condition; its own re-flights where the cell names "
               "no reference). P: the score with the smoothness term from the re-flown means (the baseline scores "
               "0.5).")
    if grid:
        out.append(f"The grid oracle (oracle-copter3d, the same condition, two gains): {grid[0]}, P {grid[1]:.3f}.")
    return out
