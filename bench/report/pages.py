"""The report generator: one page per sweep (benchmarks/pages/NAME.md: the sweep's description, its command, where
its records came from, the tables its [report] declares and what its builder adds, the earlier outputs it replaced
kept as history) and BENCHMARKS.md, the headline tables of every benchmark within :data:`MAX_LINES` lines
(ksbo_bench.report.headlines).

    ksbo-bench report            # write them
    ksbo-bench report --check    # exit 1 if one is not what the stores give
"""

from __future__ import annotations

import collections
import sys
from pathlib import Path
from typing import Any

from ksbo_bench import sweep as sweeps
from ksbo_bench.report import figures
from ksbo_bench.store import Store

ROOT = sweeps.ROOT
PAGES = ROOT / "benchmarks" / "pages"
PAGE = ROOT / "BENCHMARKS.md"
MAX_LINES = 300

def _rel(path: Path, start: Path) -> str:
    import os

    return Path(os.path.relpath(path, start)).as_posix()


def provenance(sw: sweeps.Sweep, recs: list[dict[str, Any]], where: Path) -> str:
    """Command, records, code, machine, dates and executors of a sweep's records, links relative to ``where``."""
    runs = [r.get("run", {}) for r in recs]
    machines = collections.Counter(r.get("machine") or "not recorded" for r in runs)
    dates = sorted(r["started"][:10] for r in runs if r.get("started"))
    codes = sorted({r.get("code", "unknown") for r in runs})
    ex = collections.Counter(r.get("executor", "?") for r in runs)
    when = f"{dates[0]} to {dates[-1]}" if dates and dates[0] != dates[-1] else (dates[0] if dates else "undated")
    machine = "; ".join(f"{m} ({n})" if len(machines) > 1 else m for m, n in machines.most_common(3))
    return (f"Command: `ksbo-bench run {sw.name}` ([{_rel(sw.path, ROOT)}]({_rel(sw.path, where)}), kind "
            f"`{sw.kind}`). Records: {len(recs)} in [{_rel(sw.store, ROOT)}]({_rel(sw.store / 'records.jsonl', where)})"
            f", {when}, code {', '.join(codes[:4])}{' …' if len(codes) > 4 else ''}, executor "
            f"{', '.join(f'{k} ({v})' for k, v in ex.items())}. Machine: {machine}.")


def _order(sw: sweeps.Sweep) -> dict[str, list[Any]]:
    out: dict[str, list[Any]] = {}
    for cell in sw.cells():
        for k, v in cell.key.items():
            if not isinstance(v, (dict, list)) and v not in out.setdefault(k, []):
                out[k].append(v)
    return out


def tables(sw: sweeps.Sweep, recs: list[dict[str, Any]]) -> list[str]:
    """The sweep's declared tables, each with its caption."""
    out = []
    for spec in sw.report.get("table", []):
        if spec.get("title"):
            out.append(f"**{spec['title']}**")
        out.append(figures.table(recs, spec, _order(sw)))
    return out


def _evaluation(sw: sweeps.Sweep, recs: list[dict[str, Any]]) -> list[str]:
    """Each evaluation's own part (its module's ``report``), in the order the sweep declares them."""
    from ksbo_bench.kinds.evaluate import module

    out = []
    for what in dict.fromkeys(r["key"]["what"] for r in recs):
        fn = getattr(module(what), "report", None)
        if fn:
            out.append(fn([r for r in recs if r["key"]["what"] == what]))
    return out


def _builders() -> dict[str, Any]:
    from ksbo_bench.report import (campaign_pages, fault_matrix, flight_pages, oracle, realtime, wind_campaigns,
                                   wind_inference)

    return {"warm-start": campaign_pages.warm_start, "drift": campaign_pages.drift,
            "link-campaign": campaign_pages.link_campaign, "mavlink-campaign": campaign_pages.mavlink_campaign,
            "realtime": realtime.report, "flights": flight_pages.report, "oracle": oracle.report,
            "one-pack": oracle.one_pack,
            "evaluation": _evaluation,
            "fault-matrix": lambda sw, recs: [fault_matrix.report(recs)],
            "wind": lambda sw, recs: [wind_inference.report(recs)], "wind-campaigns": wind_campaigns.page}


def ordered(sw: sweeps.Sweep, recs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """``recs`` in the order the sweep declares its cells; records of no declared cell (history) after them."""
    index = {c.id: i for i, c in enumerate(sw.cells())}
    return sorted(recs, key=lambda r: index.get(sweeps.key_id(r["key"]), len(index)))


def archived(sw: sweeps.Sweep, where: Path) -> str:
    """The line naming the earlier outputs this sweep's page replaces, kept as history (``[report] archive``)."""
    files = [ROOT / a for a in sw.report.get("archive", [])]
    if not files:
        return ""
    return ("Kept as history (the output of the script this sweep replaced, measured with the code of its day; its "
            "numbers are not these records'): " + ", ".join(f"[{_rel(f, ROOT)}]({_rel(f, where)})" for f in files)
            + ".")


def blocks(sw: sweeps.Sweep, recs: list[dict[str, Any]]) -> list[str]:
    """The page's body: the declared tables, then what the sweep's builder (``[report] builder``) adds."""
    out = tables(sw, recs)
    builder = sw.report.get("builder")
    if builder == "plants":
        from ksbo_bench.report.plants import flat, report

        out += ["## Every setting", report([flat(r) for r in recs], fly=False)]
    elif builder == "paper":  # figures drawn by python -m ksbo_bench.report.paper_figures
        out += [f"![{s}](../../docs/figures/campaign_{s}.png)" for s in ("vehicle", "paper", "trajectory")
                if (ROOT / "docs" / "figures" / f"campaign_{s}.png").is_file()]
    elif builder == "short-campaign":
        from ksbo_bench.report.short_campaign import report

        out.append(report(recs))
    elif builder:
        out += _builders()[builder](sw, ordered(sw, recs))
    return [b.strip("\n") for text in out for b in text.split("\n\n") if b.strip()]


def page(sw: sweeps.Sweep, recs: list[dict[str, Any]]) -> str:
    parts = [f"# {sw.title}", sw.description.replace("\n", " ").strip(), provenance(sw, recs, PAGES),
             *blocks(sw, recs), archived(sw, PAGES)]
    return "\n\n".join(p for p in parts if p).rstrip() + "\n"


def _loaded() -> dict[str, tuple[sweeps.Sweep, list[dict[str, Any]]]]:
    return {sw.name: (sw, Store(sw.store).records()) for sw in sweeps.all_sweeps()}


def build() -> dict[Path, str]:
    """Every page's path and text."""
    from ksbo_bench.report.headlines import benchmarks

    loaded = _loaded()
    out = {PAGES / f"{name}.md": page(sw, recs) for name, (sw, recs) in loaded.items() if recs}
    out[PAGE] = benchmarks(loaded, lambda sw, recs: (provenance(sw, recs, ROOT), blocks(sw, recs)))
    return out


def main(check: bool = False) -> int:
    try:
        pages = build()
    except (OSError, ValueError, KeyError, IndexError) as exc:
        print(f"ksbo-bench report: cannot build the pages: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 2
    n = len(pages[PAGE].splitlines())
    if n > MAX_LINES:
        print(f"ksbo-bench report: BENCHMARKS.md would be {n} lines (at most {MAX_LINES}): move a table to its "
              "sweep's page", file=sys.stderr)
        return 2
    stale = [p for p, text in pages.items() if not p.is_file() or p.read_text() != text]
    if check:
        for p in stale:
            print(f"ksbo-bench report: {_rel(p, ROOT)} is not what the records give; run ksbo-bench report",
                  file=sys.stderr)
        if not stale:
            print(f"{len(pages)} pages up to date (BENCHMARKS.md {n} lines)")
        return 1 if stale else 0
    PAGES.mkdir(parents=True, exist_ok=True)
    for p in stale:
        p.write_text(pages[p])
    print(f"wrote {len(stale)} of {len(pages)} pages (BENCHMARKS.md {n} lines)")
    return 0
