"""The campaign's report page: one self-contained XHTML-compatible file (report/index.html).

Verdict first (before -> after lap RMS with the re-flight noise, gains changed, flights flown, where the search box
capped the result, everything unsafe / aborted / crashed / interrupted counted apart), then the plots (embedded as
base64 PNG data URIs: no network, no script) and the table of every flown trial, numbered as on the console. All
text goes through :func:`html.escape`.
"""

from __future__ import annotations

import base64
import html
import time
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ksbo_mav.campaign.box_edge import EdgeHit
from ksbo_mav.campaign.report.rows import SAFETY, CampaignRecord, TrialRow

#: Plots in the order the page shows them, with their captions.
PLOTS = (
    ("convergence", "P of every flown trial (prior, baseline re-flights and confirmations included)."),
    ("trajectory", "The baseline and the tuned gains flying the figure-8, in the vehicle's frame."),
    ("gains", "Each gain through the campaign against its search box and the profile's limits."),
    ("conditions", "The baseline gains at each re-flight, and the wind and battery voltage each trial flew in."),
    ("safety", "Cumulative counts of unsafe, aborted, crashed and interrupted trials."),
)

STYLE = """
body { font-family: sans-serif; margin: 1.5em auto; max-width: 1150px; color: #222; }
h1 { font-size: 1.4em; } h2 { font-size: 1.15em; margin-top: 1.6em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; font-size: 0.8em; } .wide { overflow-x: auto; }
.headline { font-weight: bold; font-size: 1.1em; margin: 0.2em 0 0.6em 0; }
td, th { padding: 0.15em 0.45em; border-bottom: 1px solid #e4e4e4; text-align: right; white-space: nowrap; }
th { background: #f2f2f2; } td.l, th.l { text-align: left; } td.o { white-space: normal; min-width: 14em; }
.verdict { background: #f5f9ff; border: 1px solid #b8cde8; padding: 0.6em 1em; }
.verdict th { background: none; text-align: left; vertical-align: top; }
.verdict td { text-align: left; white-space: normal; }
.warn { color: #a40000; } .edge { background: #fff4e0; border-left: 4px solid #e69500; padding: 0.3em 0.6em; }
tr.bad td { background: #fde8e8; } tr.crash td { background: #f6c8c8; } tr.off td { color: #888; }
tr.confirm td { background: #eaf6ea; } tr.base td { background: #f0f0f0; }
figure { margin: 1em 0; } figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 0.85em; color: #555; }
"""


def esc(value: Any) -> str:
    return html.escape(str(value), quote=True)


def _num(v: float | None, fmt: str = ".5g") -> str:
    return "–" if v is None or not np.isfinite(v) else format(v, fmt)


def spread(values: Sequence[float]) -> str:
    """Mean of repeated flights with their spread: "0.215 m (2 flights, 0.212–0.218)"."""
    v = [x for x in values if x is not None]
    if not v:
        return "not measured"
    if len(v) == 1:
        return f"{v[0]:.3f} m (1 flight: re-flight noise not measured)"
    return f"{np.mean(v):.3f} m ({len(v)} flights, {min(v):.3f}–{max(v):.3f})"


def headline(rec: CampaignRecord, result: dict[str, Any] | None) -> str:
    """One sentence: did the tracking improve, by how much, against the re-flight noise."""
    base = [r.rms for r in rec.of("baseline", "baseline re-flight") if r.entry.outcome == "ok" and r.rms is not None]
    conf = rec.of("confirmation")
    done = [r.rms for r in conf if r.entry.outcome == "ok" and r.rms is not None]
    failures = (result or {}).get("best", {}).get("confirm_failures") or []
    if failures:
        return "Not confirmed: " + "; ".join(str(f) for f in failures) + " (the baseline gains stay unless forced)"
    if not result:
        return "Unfinished campaign: the trials flown so far"
    if not base or not done:
        return "No before / after comparison: " + ("the recommendation was not re-flown" if not conf
                                                      else "no completed flight to compare")
    before, after = float(np.mean(base)), float(np.mean(done))
    repeated = [(max(v) - min(v), len(v), name) for v, name in ((base, "baseline"), (done, "confirmation"))
                if len(v) > 1]
    noise = max(repeated)[0] if repeated else None
    spread_of = ", ".join(f"{n} {name} flights" for _, n, name in repeated)
    change = (after - before) / before if before > 0 else 0.0
    pct = f"{abs(change):.1%}" if abs(change) < 0.1 else f"{abs(change):.0%}"
    values = f"{before:.3f} m → {after:.3f} m"
    if noise is None:
        return (f"Lap RMS tracking error {'down' if after < before else 'up'} {pct}: {values} (single flights: "
                "re-fly to measure the noise)")
    spread_note = f"spread {noise:.3f} m over {spread_of}"
    if abs(after - before) <= noise:
        return f"Lap RMS tracking error unchanged within the re-flight noise: {values} ({spread_note})"
    return (f"Lap RMS tracking error {'down' if after < before else 'up'} {pct}: {values}, beyond the re-flight "
            f"noise ({spread_note})")


def counts(rec: CampaignRecord) -> dict[str, int]:
    """Safety counted four ways, as the console counts them."""
    return {label: sum(label in r.safety for r in rec.rows) for label in SAFETY}


def verdict_rows(rec: CampaignRecord, result: dict[str, Any] | None, hits: Sequence[EdgeHit]) -> list[tuple[str, str]]:
    """(label, XHTML) rows of the verdict box; a new fact (e.g. batteries) is one more row."""
    rows: list[tuple[str, str]] = status_rows(result)
    base = [r.rms for r in rec.of("baseline", "baseline re-flight") if r.entry.outcome == "ok"]
    flown = rec.of("confirmation")
    conf = [r.rms for r in flown if r.entry.outcome == "ok"]
    after = (spread(conf) if conf else f"no completed confirmation flight ({len(flown)} flown)" if flown
             else "the recommendation was not re-flown")
    rows.append(("Lap RMS error", f"{esc(spread(base))} &#8594; {esc(after)}"))
    if result and result.get("best"):
        best = result["best"]
        pc = best.get("P_confirm")
        rows.append(("P", esc(f"{result['baseline']['P']:+.4f} → "
                              + (f"{pc:+.4f} re-flown" if pc is not None else f"{best['P_model']:+.4f} (model)"))))
        changed = [(n, result["baseline"]["values"][n], v) for n, v in best["values"].items()
                   if not np.isclose(v, result["baseline"]["values"][n], rtol=1e-6, atol=1e-9)]
        rows.append(("Gains changed", "<br/>".join(f"<code>{esc(n)}</code> {esc(_num(a))} &#8594; {esc(_num(b))}"
                                                  for n, a, b in changed) or "none"))
        held = "the tuned gains (accepted)" if result.get("accepted") else "the baseline gains (restored)"
        rows.append(("Vehicle holds", esc(held + (f"; --accept refused: {result['accept_refused']}"
                                                  if result.get("accept_refused") else ""))))
    by_role: dict[str, int] = {}
    for r in rec.rows:
        role = "re-flight" if r.role.startswith("re-flight") else r.role
        by_role[role] = by_role.get(role, 0) + 1
    if result and result.get("search_end"):
        rows.append(("Search ended", esc(result["search_end"]["text"])))
    elif result and (rec.settings.get("config") or {}).get("early_stop") is False:
        rows.append(("Search ended", "the whole budget flown (early stop off: --no-early-stop)"))
    if rec.settings.get("firmware"):  # the line the tool said at connect (docs/firmware.md)
        rows.append(("Firmware", "<br/>".join(esc(line) for line in rec.settings["firmware"])))
    rows.append(("Flights", esc(f"{len(rec.rows)} ("
                                + ", ".join(f"{n} {role}" for role, n in by_role.items()) + ")")))
    if result and result.get("link"):
        from ksbo_mav.mav.linkcheck import LinkFigures

        fig = LinkFigures(**{k: v for k, v in result["link"].items() if k not in ("at", "on_link_loss")})
        flown = (rec.settings.get("mission") or {}).get("rate_hz")
        rows.append(("Link", esc(fig.describe() + (f"; flown at {flown} Hz, the profile's {fig.reduced_from_hz} Hz "
                                                   "did not fit the link" if fig.reduced_from_hz else ""))))
        if result["link"].get("on_link_loss"):
            rows.append(("If the link dies", esc(result["link"]["on_link_loss"])))
    if result and result.get("wind"):
        rows.append(("Wind", esc(result["wind"])))
    if result and result.get("validation_lines"):
        rows.append(("Validation", "<br/>".join(esc(line) for line in result["validation_lines"])))
    if result and result.get("drift"):
        rows.append(("Vehicle changed", f'<span class="warn">{esc(result["drift"])}</span>'))
    if result and result.get("same_condition"):
        rows.append(("Same condition", esc(result["same_condition"])))
    if result and result.get("batteries") is not None:
        rows.append(("Batteries", esc(result["batteries"])))
    c = counts(rec)
    text = ", ".join(f"{k} {v}" for k, v in c.items())
    rows.append(("Safety", f'<span class="warn">{esc(text)}</span>' if any(c.values()) else esc(text)))
    if hits:
        rows.append(("Search box", "".join(f'<div class="edge">{esc(h.message())}</div>' for h in hits)))
    elif result:
        rows.append(("Search box", "the recommendation lies inside the search box"))
    return rows


def status_rows(result: dict[str, Any] | None) -> list[tuple[str, str]]:
    """Where the campaign stands when it is not done: stopped (why, the command that continues), or tuned with its
    validation flights pending or incomplete (the command that flies the rest)."""
    rows = []
    stopped = (result or {}).get("stopped")
    if stopped:
        rows.append(("Stopped", f'<span class="warn">{esc(stopped["reason"])}</span><br/>continue: '
                                f'<code>{esc(stopped["command"])}</code>'))
    checked = (result or {}).get("validation") or {}
    if checked.get("state") == "incomplete":
        rows.append(("Status", esc(f"tuned; validation incomplete: {checked.get('reason')}; ")
                     + f'<code>{esc(checked.get("command"))}</code> flies the rest'))
    elif checked.get("state") == "pending":
        rows.append(("Status", "tuned; the validation flights not flown yet: "
                     f'<code>{esc(checked.get("command"))}</code> flies them'))
    return rows


def _img(path: str) -> str:
    data = base64.b64encode(Path(path).read_bytes()).decode("ascii")
    return f'<img alt="{esc(Path(path).stem)}" src="data:image/png;base64,{data}"/>'


def _row_class(r: TrialRow) -> str:
    if r.kind == "failed":
        return "off"
    if r.entry.outcome == "crash":
        return "crash"
    if r.entry.outcome != "ok" or r.P < 0:
        return "bad"
    return {"confirmation": "confirm", "baseline": "base", "baseline re-flight": "base"}.get(r.role, "")


def trial_table(rec: CampaignRecord) -> str:
    head = "".join(f"<th>{esc(n)}</th>" for n in rec.names)
    rough = any(r.entry.rough is not None for r in rec.rows)  # 3-D missions: the lap's body-rate roughness
    out = ['<table><tr><th>trial</th><th class="l">kind</th><th>P</th><th>lap RMS (m)</th>'
           + ('<th>roughness (deg/s)</th>' if rough else '') + f'<th class="l">outcome</th>{head}</tr>']
    for r in rec.rows:
        gains = "".join(f"<td>{esc(_num(r.values[n]))}</td>" for n in rec.names)
        cls = _row_class(r)
        attr = f' class="{cls}"' if cls else ""
        shake = f'<td>{esc(_num(r.entry.rough, ".2f"))}</td>' if rough else ""
        out.append(f'<tr{attr}><td>{r.trial}</td>'
                   f'<td class="l">{esc(r.role)}</td><td>{esc(_num(r.P, "+.4f"))}</td>'
                   f'<td>{esc(_num(r.rms, ".3f"))}</td>{shake}<td class="l o">{esc(r.outcome_text)}</td>{gains}</tr>')
    out.append("</table>")
    return "\n".join(out)


def render(rec: CampaignRecord, result: dict[str, Any] | None, hits: Sequence[EdgeHit], plots: dict[str, str],
           title: str) -> str:
    """The page as one string."""
    verdict = "\n".join(f'<tr><th>{esc(k)}</th><td>{v}</td></tr>' for k, v in verdict_rows(rec, result, hits))
    figures = "\n".join(f"<figure>{_img(plots[k])}<figcaption>{esc(cap)}</figcaption></figure>"
                        for k, cap in PLOTS if plots.get(k, "none") != "none" and Path(plots[k]).is_file())
    s = rec.settings
    cfg = s.get("config", {})
    prior = (f"{s['prior_simulated']} simulated episodes, nothing flown" if s.get("prior_simulated")
             else cfg.get("prior"))
    about = (f"profile {s.get('profile')}, method {cfg.get('method')}, budget {cfg.get('budget')}, seed "
             f"{cfg.get('seed')}, prior {prior}"
             + ("; flown WITHOUT the onboard guard (--no-onboard-guard)" if cfg.get("onboard_guard") is False else "")
             + ("; figure-8s streamed from the ground (--trial-source ground)"
                if cfg.get("trial_source") == "ground" else "")
             + f"; written {time.strftime('%Y-%m-%d %H:%M:%S')}")
    return f"""<!DOCTYPE html>
<html xmlns="http://www.w3.org/1999/xhtml" lang="en">
<head>
<meta charset="utf-8"/>
<title>{esc(title)}</title>
<style>{STYLE}</style>
</head>
<body>
<h1>{esc(title)}</h1>
<p>{esc(about)}</p>
<h2>Verdict</h2>
<div class="verdict"><p class="headline">{esc(headline(rec, result))}</p><table>
{verdict}
</table></div>
{(result or {}).get("validation_html", "")}
<h2>Plots</h2>
{f"<p>{esc(result['plots_note'])}</p>" if (result or {}).get("plots_note") else ""}
{figures}
<h2>Trials</h2>
<p>Numbered as on the console. Gains in the vehicle's units.</p>
<div class="wide">
{trial_table(rec)}
</div>
</body>
</html>
"""


def write_page(path: Path, rec: CampaignRecord, result: dict[str, Any] | None, hits: Sequence[EdgeHit],
               plots: dict[str, str]) -> Path:
    """Write the page to ``path`` (the plots must already exist); returns ``path``."""
    title = f"Tuning campaign {Path(rec.settings.get('config', {}).get('dir') or path.parent.parent).name}"
    path.write_text(render(rec, result, hits, plots, title), encoding="utf-8")
    return path
