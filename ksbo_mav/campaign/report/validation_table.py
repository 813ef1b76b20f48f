"""The report's validation section: per comparison (the recommendation, further candidates) and manoeuvre, every
figure of the baseline's and the candidate's flights with the spread of the repeats, and the plain verdict
(:mod:`ksbo_mav.campaign.verdict`); then every validation flight, numbered as on the console."""

from __future__ import annotations

import html
from typing import Any, Sequence

import numpy as np

from ksbo_mav.campaign.validation_log import ValidationEntry
from ksbo_mav.campaign.verdict import DECIDING, FALLBACK, RESOLUTION, PairVerdict, best_not_worse, judge_pairs

RULE = ("Flown alternately (baseline, candidate, baseline, candidate ...) so that a drift of the vehicle or the "
        "wind moves both alike. Verdict on the figure marked *, lower is better: worse or better when the means "
        f"differ by more than the repeats' spread (the larger range of the two, at least {RESOLUTION:.0%} of the "
        "baseline's mean), else no measurable change. These flights are never given to the optimiser.")


def _esc(v: Any) -> str:
    return html.escape(str(v), quote=True)


def figures(values: Sequence[float]) -> str:
    """"0.215 (2 flights, 0.212–0.218)"."""
    v = [x for x in values if x is not None and np.isfinite(x)]
    if not v:
        return "–"
    if len(v) == 1:
        return f"{v[0]:.3g} (1 flight)"
    return f"{np.mean(v):.3g} ({len(v)} flights, {min(v):.3g}–{max(v):.3g})"


def verdict_lines(entries: Sequence[ValidationEntry]) -> list[str]:
    """The verdict box's lines: one per comparison and manoeuvre, and the best candidate when it matters."""
    verdicts = judge_pairs(entries)
    out = [f"{p.pair}: {line}" for p in verdicts for line in p.lines()]
    if verdicts and verdicts[0].worse_on:
        best = best_not_worse(verdicts)
        out.append(f"best candidate worse nowhere: {best.pair}" if best else
                   "no candidate flown is worse nowhere: keep the baseline gains")
    return out


def _pair_table(p: PairVerdict, entries: Sequence[ValidationEntry]) -> str:
    rows = ['<table><tr><th class="l">manoeuvre</th><th class="l">figure</th><th>baseline</th>'
            f'<th>{_esc(p.pair)}</th><th class="l">verdict</th></tr>']
    for m, j in p.judged.items():
        mine = [e for e in entries if e.pair == p.pair and e.manoeuvre == m and e.counted and e.outcome == "ok"]
        names = list(dict.fromkeys(k for e in mine for k in e.metrics))
        deciding = j.metric
        names = ([deciding] if deciding in names else []) + [n for n in names if n != deciding]
        for i, name in enumerate(names or ["(no figure)"]):
            base = [e.metrics.get(name) for e in mine if e.gains == "baseline"]
            cand = [e.metrics.get(name) for e in mine if e.gains != "baseline"]
            mark = " *" if name == deciding else ""
            verdict = _esc(j.verdict + "".join(f"; {n} {who} aborted" for n, who in
                                              ((j.base_aborted, "baseline"), (j.cand_aborted, "candidate")) if n))
            rows.append(f'<tr><td class="l">{_esc(m) if i == 0 else ""}</td><td class="l">{_esc(name + mark)}</td>'
                        f'<td>{_esc(figures(base))}</td><td>{_esc(figures(cand))}</td>'
                        f'<td class="l">{verdict if i == 0 else ""}</td></tr>')
    rows.append("</table>")
    return "\n".join(rows)


def flight_table(entries: Sequence[ValidationEntry]) -> str:
    rows = ['<table><tr><th>flight</th><th class="l">manoeuvre</th><th class="l">comparison</th>'
            '<th class="l">gains</th><th class="l">outcome</th><th>deciding figure</th><th class="l">wind</th></tr>']
    for e in entries:
        value = e.metrics.get(DECIDING.get(e.manoeuvre, ""), e.metrics.get(FALLBACK.get(e.manoeuvre, "")))
        outcome = "completed" if e.outcome == "ok" else (
            f"aborted by the monitor ({e.outcome.text})" if e.counted else
            f"not counted ({e.outcome.text}" + (f": {e.message[:300]})" if e.message else ")"))
        rows.append(f'<tr><td>{e.flight}</td><td class="l">{_esc(e.manoeuvre)}</td><td class="l">{_esc(e.pair)}</td>'
                    f'<td class="l">{_esc(e.gains)}</td><td class="l o">{_esc(outcome)}</td>'
                    f'<td>{_esc("–" if value is None else format(value, ".4g"))}</td>'
                    f'<td class="l">{_esc(wind_text(e.cond))}</td></tr>')
    rows.append("</table>")
    return "\n".join(rows)


def wind_text(cond: dict[str, Any] | None) -> str:
    """A flight's wind as the vehicle gave it: its estimate, or "not estimated by the vehicle" (never a 0 it did
    not measure), with an inferred figure where one was computed."""
    cond = cond or {}
    if cond.get("wind_estimated") is False:
        text = "not estimated by the vehicle"
    elif cond.get("wind_mps") is not None:
        text = f"{cond['wind_mps']:.1f} m/s (vehicle estimate)"
    else:
        text = "none received"
    if cond.get("wind_inferred_mps") is not None:
        text += f"; inferred {cond['wind_inferred_mps']:.1f} m/s ({cond.get('wind_inferred_how', 'see docs')})"
    return text


def validation_section(entries: Sequence[ValidationEntry]) -> str:
    """The page's validation section (empty string without validation flights)."""
    if not entries:
        return ""
    parts = ["<h2>Validation flights</h2>", f"<p>{_esc(RULE)}</p>"]
    for p in judge_pairs(entries):
        parts.append(f"<h3>{_esc(p.pair)} against the baseline: {_esc(p.overall)}</h3>")
        parts.append(f'<div class="wide">{_pair_table(p, entries)}</div>')
    parts.append(f'<div class="wide">{flight_table(entries)}</div>')
    return "\n".join(parts)
