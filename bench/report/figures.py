"""A record's figures by name and the summaries a sweep's [report] tables ask for.

A figure is a dotted path into the record (``safety.crashed``, ``timing.seconds``) or a bare name looked up in
``result``, then ``safety``, ``flights``, ``timing``, ``key``. A table (``[[report.table]]`` in the sweep file)::

    [[report.table]]
    title = "With the monitor"          # a bold caption
    rows = "plant"                      # a key name: one row per value, in the sweep's order
    columns = "method"                  # optional: a key name, its values side by side
    cells = ["EP:median-range:E[P]", "safety.crashed:zero-share:crash-free seeds"]
    where = { mode = "monitor" }        # optional: only records with these key values

Each cell is FIGURE:SUMMARY[:HEADER] over the records of the row (and column): the seeds, usually. ``rows =
"cell"``: one row per record, named by its key's values (those in ``hide`` left out), for sweeps whose cells
differ in more than one value (the speed sweep's timings).
"""

from __future__ import annotations

import statistics
from typing import Any, Callable

import numpy as np

PARTS = ("result", "safety", "flights", "timing", "key")


def value(rec: dict[str, Any], path: str) -> Any:
    if "." in path:
        head, _, rest = path.partition(".")
        v = rec.get(head, {})
        for p in rest.split("."):
            v = v.get(p) if isinstance(v, dict) else None
        return v
    for part in PARTS:
        if path in rec.get(part, {}):
            return rec[part][path]
    return None


def _nums(vs: list[Any]) -> list[float]:
    return [float(v) for v in vs if isinstance(v, (int, float)) and v is not None and np.isfinite(v)]


def _median_range(vs: list[Any], fmt: str = "{:.3f}") -> str:
    v = _nums(vs)
    missing = len(vs) - len(v)
    if not v:
        return "–"
    s = f"{fmt.format(statistics.median(v))} [{fmt.format(min(v))}, {fmt.format(max(v))}]"
    return s + (f", {missing} none" if missing else "")


def _seconds(v: float) -> str:
    """A duration: ms below a second, else s (3 significant digits)."""
    return f"{v * 1e3:.3g} ms" if v < 1 else f"{v:.3g} s"


SUMMARIES: dict[str, Callable[[list[Any]], str]] = {
    "median-range": _median_range,
    "pct-median-range": lambda vs: _median_range([None if x is None else 100 * x for x in vs], "{:+.0f} %"),
    "median": lambda vs: f"{statistics.median(_nums(vs)):.3g}" if _nums(vs) else "–",
    "median-max": lambda vs: f"{statistics.median(_nums(vs)):.0f} [{max(_nums(vs)):.0f}]" if _nums(vs) else "–",
    "zero-share": lambda vs: f"{sum(1 for x in vs if x == 0)}/{len(vs)}",
    "sum": lambda vs: f"{sum(_nums(vs)):g}",
    "n": lambda vs: f"{len(vs)}",
    "min-ms": lambda vs: _seconds(min(_nums(vs))) if _nums(vs) else "–",
    "min-x": lambda vs: f"{min(_nums(vs)):,.0f}x" if _nums(vs) else "–",
    "max-x": lambda vs: f"{max(_nums(vs)):,.0f}x" if _nums(vs) else "–",
    "list": lambda vs: ", ".join("–" if x is None else f"{x:g}" if isinstance(x, (int, float)) else str(x)
                                 for x in vs),
}


def _per_record(rs: list[dict[str, Any]], spec: dict[str, Any]) -> str:
    hide = set(spec.get("hide", []))
    cells = [c.split(":") for c in spec["cells"]]
    lines = ["| cell | " + " | ".join(p[2] if len(p) > 2 else p[0] for p in cells) + " |",
             "|" + "---|" * (len(cells) + 1)]
    for r in rs:
        name = " ".join(str(v) for k, v in r["key"].items() if k not in hide and not isinstance(v, (dict, list)))
        lines.append(f"| {name} | " + " | ".join(SUMMARIES[p[1]]([value(r, p[0])]) for p in cells) + " |")
    return "\n".join(lines)


def _order(values: list[Any]) -> list[Any]:
    seen: list[Any] = []
    for v in values:
        if v not in seen:
            seen.append(v)
    return seen


def table(recs: list[dict[str, Any]], spec: dict[str, Any], order: dict[str, list[Any]] | None = None) -> str:
    """The Markdown table ``spec`` asks for (see the module's docstring); ``order``: each key's values in the
    sweep's declared order (else first seen)."""
    where = spec.get("where", {})
    rs = [r for r in recs if all(r["key"].get(k) == v for k, v in where.items())]
    if spec["rows"] == "cell":
        return _per_record(rs, spec)
    rows_by, cols_by = spec["rows"], spec.get("columns")
    order = order or {}
    rows = [v for v in order.get(rows_by, []) if any(r["key"].get(rows_by) == v for r in rs)] or \
        _order([r["key"].get(rows_by) for r in rs])
    cols = ([v for v in order.get(cols_by, []) if any(r["key"].get(cols_by) == v for r in rs)]
            or _order([r["key"].get(cols_by) for r in rs])) if cols_by else [None]
    cells = [c.split(":") for c in spec["cells"]]
    head = [rows_by] + [(f"`{c}` " if c is not None else "") + (p[2] if len(p) > 2 else p[0])
                        for c in cols for p in cells]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for row in rows:
        out = [str(row)]
        for col in cols:
            sel = [r for r in rs if r["key"].get(rows_by) == row and (cols_by is None or r["key"].get(cols_by) == col)]
            for p in cells:
                out.append(SUMMARIES[p[1]]([value(r, p[0]) for r in sel]) if sel else "–")
        lines.append("| " + " | ".join(out) + " |")
    return "\n".join(lines)
