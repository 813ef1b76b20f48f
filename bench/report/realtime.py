"""The real-time campaigns' page: one row per campaign (flights, search end, the training figure-8 before and
after, whether the tool kept real time, safety, the validation's verdict), the training score against the
validation's position steps, and the validation figures of the recommendation against the baseline."""

from __future__ import annotations

import statistics
from typing import Any

from ksbo_bench.report.describe import mean

VERDICT_WORST = ("worse", "no measurable change", "better")


def _worst(verdicts: list[str]) -> str:
    return min(verdicts, key=lambda v: VERDICT_WORST.index(v) if v in VERDICT_WORST else -1) if verdicts else "–"


def _m(xs: list[float] | None) -> str:
    v = mean(xs)
    return "–" if v is None else f"{v:.3f}"


def _change(base: list[float], cand: list[float]) -> str:
    return f" ({statistics.mean(cand) / statistics.mean(base) - 1:+.0%})" if base and cand else ""


def _fig(xs: list[float]) -> str:
    return (f"{statistics.mean(xs):.3g} ({min(xs):.3g}–{max(xs):.3g})" if len(xs) > 1
            else f"{xs[0]:.3g}" if xs else "–")


def _leans(xs: list[float | None] | None) -> str:
    xs = [x for x in xs or [] if x is not None]
    return " / ".join(f"{x:.1f}" for x in xs) if xs else "–"


def _late(res: dict) -> str:
    if res.get("figure8") == "on board" and res.get("lag_max_ms") is None:
        return "none streamed (on board)"
    lag = res.get("lag_max_ms")
    return f"{lag if lag is not None else '–'}, {(res.get('late_fraction_max') or 0):.1%}"


def _sensors(r: dict) -> str:
    k = r["key"]
    seed = f", seed {k['seed']}" if k.get("seed") else ""
    return f"{k.get('label', '')}{seed}"


def report(sw, recs: list[dict[str, Any]]) -> list[str]:
    rows = ["| stack | configuration | training figure-8 | flights to result (optimiser + confirm) | search end | "
            "lap-2 RMS baseline → recommendation (m) | setpoints late: max (ms), share | LOCAL_POSITION_NED min (Hz) | "
            "interrupted / aborted / P<0 / crashed | validation flights (wall s) | verdict of the recommendation |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    detail = ["| stack | configuration | manoeuvre | figure | baseline mean (min–max) | recommendation mean (min–max) "
              "| change | verdict |", "|---|---|---|---|---|---|---|---|"]
    transfer = ["| stack | configuration | training trial | trials aborted on the step | training step lean (deg): "
                "baseline; confirmation | validation step flights: peak lean (deg) baseline → recommendation | "
                "recommendation's step flights aborted |", "|---|---|---|---|---|---|---|"]
    for r in recs:
        res, s, k = r["result"], r["safety"], r["key"]
        lab = res.get("flights_by_label", {})
        rec = res.get("verdicts", {}).get("recommendation", {})
        words = "; ".join(f"{m}: {v['verdict']}" for m, v in rec.items()) or "not flown"
        for pair, judged in res.get("verdicts", {}).items():
            if pair != "recommendation":
                each = "; ".join(f"{m} {v['verdict']}" for m, v in judged.items())
                words += f"; next candidate flown, {pair}: {_worst([v['verdict'] for v in judged.values()])} ({each})"
        conf = _sensors(r)
        rows.append(f"| {k['vehicle']} | {conf} | {res.get('figure8', 'streamed')} | {r['flights'].get('total')} "
                    f"({lab.get('baseline', 0) + lab.get('opt', 0)} + {lab.get('confirm', 0)}) | "
                    f"{res.get('search_end_text', '–')} | {_m(res.get('baseline_rms'))} → {_m(res.get('confirm_rms'))}"
                    f"{_change(res.get('baseline_rms'), res.get('confirm_rms'))} | {_late(res)} | "
                    f"{res.get('rate_hz_min') or '–'} | {s.get('interrupted')} / {s.get('aborted')} / "
                    f"{s.get('unsafe')} / {s.get('crashed')} | {res.get('validation_flights')} "
                    f"({res.get('validation_wall_s') or 0:.0f}) | {words} |")
        for m, v in rec.items():
            change = (f"{statistics.mean(v['cand']) / statistics.mean(v['base']) - 1:+.0%}"
                      if v["base"] and v["cand"] else "–")
            detail.append(f"| {k['vehicle']} | {conf} | {m} | {v['metric']} | {_fig(v['base'])} | {_fig(v['cand'])} | "
                          f"{change} | {v['verdict']} |")
        leans = res.get("validation_step_leans")
        if leans:
            trained = res.get("trial_step_leans", {})
            steps = rec.get("steps", {})
            transfer.append(f"| {k['vehicle']} | {conf} | {'figure-8 + step' if res.get('trial_step') else 'figure-8'} "
                            f"| {res.get('trial_step_aborts', 0) if res.get('trial_step') else '–'} | "
                            f"{_leans(trained.get('opt', [])[:1])}; {_leans(trained.get('confirm'))} | "
                            f"{_leans(leans.get('baseline'))} → {_leans(leans.get('recommendation'))} | "
                            f"{steps.get('cand_aborted', '–')} of {len(leans.get('recommendation', []))} |")
    out = ["\n".join(rows)]
    if len(transfer) > 2:
        out += ["The training score against the validation's position steps: the training trial with the figure-8 "
                "alone, or with the position step after it (`tune --trial-step`); lean = acos(cos roll · cos pitch) of "
                "the tlog's ATTITUDE, the training step's from the trial records (the baseline's first trial; the "
                "confirmation), the validation's from each step flight's tlog between its markers.",
                "\n".join(transfer)]
    out += ["Validation figures of the recommendation against the baseline (steps: mean settling time s, or the mean "
            "overshoot % where a step did not settle within its dwell; hold: RMS drift m; AUTO mission: cross-track "
            "RMS m; lower is better):", "\n".join(detail)]
    notes = [f"- {r['key']['vehicle']}, {_sensors(r)}: {r['result']['note']}" for r in recs if r["result"].get("note")]
    if notes:
        out += ["How each converted campaign was run:", "\n".join(notes)]
    return out
