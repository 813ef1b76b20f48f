"""Cell kind ``evaluation``: one deterministic computation that is not a campaign — the planar task's statistics,
the JSBSim copter's tracking against its gains, the planar landscape around a0, kernel selection on known
functions and simulator priors, scoring logs of every format intact and damaged. Each is a module of
``ksbo_bench.evaluations`` named by the key's ``what``, with ``run(key) -> result`` (its figures), optionally
``check(key)``, ``resources(key)`` and ``report(records) -> Markdown`` (its part of the sweep's page: ``[report]
builder = "evaluation"``).

Key: ``what`` (one of :data:`EVALUATIONS`) and the evaluation's own values (its module's docstring).
"""

from __future__ import annotations

import importlib
from typing import Any

from ksbo_bench.cell_errors import SweepError

EVALUATIONS = {
    "planar-task": "ksbo_bench.evaluations.planar_task",
    "copter3d-tracking": "ksbo_bench.evaluations.copter3d_tracking",
    "landscape": "ksbo_bench.evaluations.landscape",
    "kernel-selection": "ksbo_bench.evaluations.kernel_selection",
    "log-field": "ksbo_bench.evaluations.log_field",
}


def module(what: str):
    if what not in EVALUATIONS:
        raise SweepError(f"evaluation: what must be one of {', '.join(EVALUATIONS)}, not {what!r}")
    return importlib.import_module(EVALUATIONS[what])


def check(key: dict[str, Any]) -> None:
    fn = getattr(module(key["what"]), "check", None)
    if fn:
        fn(key)


def resources(key: dict[str, Any]) -> dict[str, float]:
    fn = getattr(module(key["what"]), "resources", None)
    return fn(key) if fn else {}


def run(key: dict[str, Any], inputs: dict[str, Any] | None = None) -> dict[str, Any]:
    out = module(key["what"]).run(key)
    return {"flights": out.pop("flights", {}), "safety": out.pop("safety", {}), "timing": out.pop("timing", {}),
            "result": out}
