"""The validation flights in a tlog, re-measured from its packets alone: what ``ksbo-mav score`` and ``ksbo-mav
compare`` print for a tlog that carries the ``ksbo val`` markers (:mod:`.manoeuvre_recorder`).

The figures come from the same recorder and the same functions as the live flight, fed the same decoded packets, so
they equal what the flight reported.
"""

from __future__ import annotations

import math
import mmap
from pathlib import Path
from typing import Any

from ksbo_mav.errors import InputError
from ksbo_mav.mav.tlog import read_tlog
from ksbo_mav.mav.validation.manoeuvre_recorder import MARK, recorders_from_tlog
from ksbo_mav.mav.validation.manoeuvre_spec import HEADLINE

#: Figures printed first, per manoeuvre (the rest follow in their recorded order).
_FIRST = {"steps": ("rise_s_mean", "overshoot_pct_mean", "settle_s_mean", "steps_unsettled"),
          "hold": ("hold_rms_m", "hold_max_m", "hold_vert_rms_m", "hold_lean_deg", "hold_s"),
          "auto_mission": ("xtrack_rms_m", "xtrack_max_m", "corner_overshoot_m_mean", "corner_settle_s_mean",
                           "time_s")}


def is_validation_tlog(path: str | Path) -> bool:
    """A tlog of one of our validation flights (it carries the ``ksbo val start`` marker)."""
    with open(path, "rb") as fh:
        try:
            with mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as mm:
                return mm.find(f"{MARK} start".encode()) >= 0
        except ValueError:  # empty file
            return False


def score_validation_tlog(path: str | Path) -> dict[str, Any]:
    """{"tlog": path, "flights": [{"kind", "gains_label", "outcome", "metrics"}, ...]} of every finished validation
    flight in the tlog; :class:`InputError` for a damaged tlog or one whose flight has no end marker."""
    recs = recorders_from_tlog(read_tlog(path))
    if not recs:
        raise InputError(f"{path}: the validation flight has no end marker ('{MARK} end ...'): the log stops "
                         "mid-flight")
    flights = [{"kind": r.kind, "gains_label": r.label, "outcome": r.outcome,
                "metrics": r.metrics() if r.outcome == "ok" else {}} for r in recs]
    return {"tlog": str(path), "flights": flights}


def ordered(kind: str, metrics: dict[str, float]) -> list[str]:
    first = [k for k in _FIRST.get(kind, ()) if k in metrics]
    return first + [k for k in metrics if k not in first]


def _v(x: float | None) -> str:
    return "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.3f}"


def format_validation(result: dict[str, Any]) -> list[str]:
    lines = []
    for i, f in enumerate(result["flights"], 1):
        lines.append(f"{result['tlog']}: validation flight {i}: {f['kind']}, gains {f['gains_label'] or '?'}, "
                     f"outcome {f['outcome']}" + (f"  (headline {HEADLINE[f['kind']]})" if f["metrics"] else ""))
        for k in ordered(f["kind"], f["metrics"]):
            lines.append(f"  {k:<26} {_v(f['metrics'][k])}")
    return lines


def compare_validation(a: str | Path, b: str | Path) -> dict[str, Any]:
    """The first validation flight of each tlog side by side: {"kind", "a", "b", "rows": [(figure, A, B)]};
    :class:`InputError` when they are not the same manoeuvre."""
    ra, rb = score_validation_tlog(a)["flights"][0], score_validation_tlog(b)["flights"][0]
    if ra["kind"] != rb["kind"]:
        raise InputError(f"{a} is a {ra['kind']} flight and {b} a {rb['kind']} flight: compare the same manoeuvre")
    keys = ordered(ra["kind"], ra["metrics"]) + [k for k in rb["metrics"] if k not in ra["metrics"]]
    rows = [(k, ra["metrics"].get(k), rb["metrics"].get(k)) for k in keys]
    return {"kind": ra["kind"], "a": {"tlog": str(a), **{k: ra[k] for k in ("gains_label", "outcome")}},
            "b": {"tlog": str(b), **{k: rb[k] for k in ("gains_label", "outcome")}}, "rows": rows}


def format_comparison(c: dict[str, Any]) -> list[str]:
    lines = [f"{c['kind']}: A {c['a']['tlog']} (gains {c['a']['gains_label']}, {c['a']['outcome']})  "
             f"B {c['b']['tlog']} (gains {c['b']['gains_label']}, {c['b']['outcome']})",
             f"  {'figure':<26} {'A':>10} {'B':>10} {'B vs A':>9}"]
    for k, x, y in c["rows"]:
        rel = ""
        if x is not None and y is not None and math.isfinite(x) and math.isfinite(y) and x != 0:
            rel = f"{100.0 * (y - x) / abs(x):+.0f} %"
        lines.append(f"  {k:<26} {_v(x):>10} {_v(y):>10} {rel:>9}")
    return lines
