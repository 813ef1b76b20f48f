"""The tables of the campaign sweeps converted from their own scripts: warm start, drift, the radio link campaign,
the MAVLink campaigns on our planar vehicle. One row per record (a campaign), its vehicle and condition in words;
records of earlier designs (labels was-…, try-…) below the current ones."""

from __future__ import annotations

import statistics
from typing import Any

from ksbo_bench.report.describe import condition, fmt, mean, vehicle


def _old(r: dict[str, Any]) -> bool:
    return str(r["key"].get("label", "")).startswith(("was-", "try-"))


def _said(text: str | None) -> str:
    return (text.split(": ", 1)[1] if text and ": " in text else text or "–").replace("|", "/")


def warm_start(sw, recs: list[dict[str, Any]]) -> list[str]:
    head = ["| vehicle | condition | flights | reached at | what it said | B (m) | E (m) | W (m) | unsafe / aborted |",
            "|---|---|---|---|---|---|---|---|---|"]
    rows, old = list(head), list(head)
    for r in recs:
        k, res = r["key"], r["result"]
        if k.get("label") == "earlier":
            continue
        ref = res.get("reflown", {})
        s = r["safety"]
        (old if _old(r) else rows).append(
            f"| {vehicle(k)} | {condition(k) if condition(k) != 'calm' else 'nothing changed'} | "
            f"{r['flights'].get('total')} | {res.get('reached_at') or '–'} | {_said(res.get('warm_start'))} | "
            f"{fmt(mean(ref.get('baseline')))} | {fmt(mean(ref.get('long')))} | {fmt(mean(ref.get('rec')))} | "
            f"{s.get('unsafe', 0)} / {(s.get('aborted') or 0) + (s.get('crashed') or 0)} |")
    earlier = [r for r in recs if r["key"].get("label") == "earlier"]
    out = ["\n".join(rows)]
    if earlier:
        out.append("The earlier campaigns: " + "; ".join(
            f"{vehicle(r['key'])}, {r['flights'].get('total')} flights" for r in earlier) + ".")
    if len(old) > 2:
        out += ["Warm starts from the long campaigns of an earlier default (label was-default):", "\n".join(old)]
    return out


def _test(res: dict[str, Any]) -> str:
    d = res.get("drift")
    if not d:
        return "did not fire"
    trial = d.split("(trial ")[1].split(",")[0] if "(trial " in d else "?"
    return f"fired at trial {trial}"


def _baseline(res: dict[str, Any]) -> str:
    b = [x[1] for x in res.get("baseline_rms", [])]
    return f"{b[0]:.3f} → {b[-1]:.3f}" if b else "–"


def _reflown(res: dict[str, Any]) -> str:
    ref = res.get("reflown", {})
    b, x = mean(ref.get("baseline")), mean(ref.get("rec"))
    if b is None or x is None:
        return "–"
    return f"{b:.3f} → {x:.3f} m (−{100 * (1 - x / b):.1f} %)"


def drift(sw, recs: list[dict[str, Any]]) -> list[str]:
    copters = [r for r in recs if r["key"]["vehicle"] != "planar"]
    static = {r["key"]["vehicle"]: r for r in copters if r["key"].get("label") == "static"
              and "--baseline-every" not in r["key"].get("tune_args", [])}
    rows = ["| vehicle | condition | `--on-drift` | flights | baseline re-flights (share of budget) | baseline lap-2 "
            "RMS (m): start → last | drift test | unsafe (for drift) | re-flown in the final condition: baseline → "
            "recommendation |", "|---|---|---|---|---|---|---|---|---|"]
    for r in copters:
        k, res = r["key"], r["result"]
        args = k.get("tune_args", [])
        mode = args[args.index("--on-drift") + 1] if "--on-drift" in args else "stop"
        every = f", `--baseline-every {args[args.index('--baseline-every') + 1]}`" if "--baseline-every" in args else ""
        test = _test(res)
        if res.get("detectable_trial") is not None:
            stopped = res.get("stopped_trial")
            test += f" (detectable at trial {res['detectable_trial']}" + (
                f"; stopped at {stopped}, {stopped - res['detectable_trial']} later)" if stopped else ")")
        n = r["flights"].get("baseline", 0)
        budget = int(args[args.index("--budget") + 1]) if "--budget" in args else None
        share = f" ({100 * n / budget:.0f} %)" if budget else ""
        st = static.get(k["vehicle"])
        gain = ""
        if mode == "continue" and st and res.get("cut") and st["result"].get("cut") and st is not r:
            gain = f"; {100 * res['cut'] / st['result']['cut']:.0f} % of the static campaign's cut"
        unsafe = f"{res.get('unsafe_told', '–')} ({res['unsafe_for_drift'] if 'unsafe_for_drift' in res else '–'})"
        rows.append(f"| {vehicle(k)} | {condition(k)}{every} | {mode} | {r['flights'].get('total')} | {n}{share} | "
                    f"{_baseline(res)} | {test} | {unsafe} | {_reflown(res)}{gain} |")
    out = ["\n".join(rows)]
    planar = [r for r in recs if r["key"]["vehicle"] == "planar"]
    if planar:
        by: dict[int, dict[str, dict]] = {}
        for r in planar:
            a = r["key"]["tune_args"]
            by.setdefault(r["key"]["seed"], {})[a[a.index("--baseline-every") + 1]] = r
        lines = ["| tune seed | re-flights (`--baseline-every 7`) | re-flown P, default | re-flown P, "
                 "`--baseline-every 0` | P < 0 trials (default / none) |", "|---|---|---|---|---|"]
        for seed, d in sorted(by.items()):
            a, b = d.get("7"), d.get("0")
            if a and b:
                lines.append(f"| {seed} | {a['flights'].get('baseline', 0)} | {fmt(a['result'].get('reflown_P'))} | "
                             f"{fmt(b['result'].get('reflown_P'))} | {a['result'].get('unsafe_flown')} / "
                             f"{b['result'].get('unsafe_flown')} |")
        out += ["**The planar task, static: with and without the re-flights** (re-flown P: the recommendation from "
                "the 8 fixed starts in process, as `ksbo-mav evaluate --fixed`)", "\n".join(lines)]
    return out


def link_campaign(sw, recs: list[dict[str, Any]]) -> list[str]:
    rows = ["| stack | exit | parameters (got of n, s, path) | rate flown | flights | aborted / unsafe / interrupted | "
            "'link lost' | campaign wall (s) | params left changed | frames lost / dropped by the buffer (down) |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    for r in recs:
        k, res, s = r["key"], r["result"], r["safety"]
        p = res.get("params")
        dn = (res.get("link") or {}).get("down", {})
        ch = res.get("changed_params", [])
        rows.append(f"| {k['vehicle']} | {res.get('rc')}{' ' + res['error'] if res.get('error') else ''} | "
                    f"{f'{p[0]} of {p[1]}, {p[2]} s, {p[3]}' if p else '–'} | {res.get('rate_hz', 50)} Hz | "
                    f"{r['flights'].get('total')} | {s.get('aborted')} / {s.get('unsafe')} / {s.get('interrupted')} | "
                    f"{res.get('link_lost', 0)} | {fmt(r['timing'].get('campaign_s'), '.0f')} | "
                    f"{len(ch)} {', '.join(ch[:5])} | {dn.get('lost', '?')} / {dn.get('dropped', '?')} |")
    return ["\n".join(rows)]


def _method(k: dict[str, Any]) -> str:
    a = list(k.get("tune_args", []))
    m = a[a.index("--method") + 1] if "--method" in a else "default"
    opts = [a[i + 1] for i, x in enumerate(a) if x == "--option"]
    return m + "".join(f" {o}" for o in opts)


def _unrestored(r: dict[str, Any]) -> int:
    """Exits that left the vehicle's parameters changed: the trials not restored, the parameters left changed."""
    return len(r["result"].get("changed_params", [])) + int(r["result"].get("unrestored_trials", 0))


def mavlink_campaign(sw, recs: list[dict[str, Any]]) -> list[str]:
    now = [r for r in recs if not _old(r)]
    lines = ["| method | seeds | median wall (s) | re-flown P (MAVLink), median | E[P] median [min, max] (baseline) | "
             "P < 0 / aborted / crashed trials, total | same optimiser in process: E[P] median | un-restored |",
             "|---|---|---|---|---|---|---|---|"]
    for method in dict.fromkeys(_method(r["key"]) for r in now):
        mine = [r for r in now if _method(r["key"]) == method]
        e = [r["result"]["EP"] for r in mine]
        tot = lambda k: sum(int(r["safety"].get(k) or 0) for r in mine)  # noqa: E731
        lines.append(
            f"| {method} | {len(mine)} | {statistics.median(r['timing'].get('campaign_s') or 0 for r in mine):.0f} | "
            f"{statistics.median(r['result']['P_confirm'] for r in mine):.3f} | {statistics.median(e):.3f} "
            f"[{min(e):.3f}, {max(e):.3f}] ({statistics.median(r['result']['EP_baseline'] for r in mine):.3f}) | "
            f"{tot('unsafe')} / {tot('aborted')} / {tot('crashed')} | "
            f"{statistics.median(r['result']['twin']['EP'] for r in mine):.3f} | "
            f"{sum(_unrestored(r) for r in mine)} |")
    old = sorted({str(r["key"].get("label")) for r in recs if _old(r)})
    out = ["\n".join(lines)]
    if old:
        out.append(f"Records of earlier designs kept in the store: {', '.join(old)} "
                   "(benchmarks/notes/plants.md says what each tried).")
    return out
