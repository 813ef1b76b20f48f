"""Whether two stores hold the same records for the cells they share (ksbo_bench.record.comparable: everything
but timing and the run's provenance), and the wall time each took."""

from __future__ import annotations

import json
from pathlib import Path

from ksbo_bench.record import comparable
from ksbo_bench.store import Store
from ksbo_bench.sweep import key_id


def _span(recs: list[dict]) -> str:
    wall = sum(r["timing"]["wall_s"] for r in recs)
    ex = sorted({r["run"]["executor"] for r in recs})
    return f"{len(recs)} records ({'/'.join(ex)}), {wall / 60:.1f} cell-minutes"


def compare(a: Path, b: Path) -> tuple[str, bool]:
    ra = {key_id(r["key"]): r for r in Store(a)}
    rb = {key_id(r["key"]): r for r in Store(b)}
    shared = sorted(set(ra) & set(rb))
    differ = [k for k in shared if json.dumps(comparable(ra[k]), sort_keys=True)
              != json.dumps(comparable(rb[k]), sort_keys=True)]
    lines = [f"{a}: {_span(list(ra.values()))}", f"{b}: {_span(list(rb.values()))}",
             f"{len(shared)} cells in both, {len(differ)} differ; only in the first {len(set(ra) - set(rb))}, "
             f"only in the second {len(set(rb) - set(ra))}"]
    for k in differ[:10]:
        lines.append(f"  differs: {k} ({', '.join(_fields(comparable(ra[k]), comparable(rb[k])))})")
    return "\n".join(lines), bool(shared) and not differ


def _fields(x: dict, y: dict) -> list[str]:
    """The fields (one level down) where two records differ."""
    out = []
    for part in sorted(set(x) | set(y)):
        u, v = x.get(part), y.get(part)
        if isinstance(u, dict) and isinstance(v, dict):
            out += [f"{part}.{f}" for f in sorted(set(u) | set(v)) if u.get(f) != v.get(f)]
        elif u != v:
            out.append(part)
    return out
