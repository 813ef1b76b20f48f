"""Cell kinds: what one cell of a sweep runs. Each kind is a module with

- ``REQUIRED`` (the key values it cannot run without) and ``check(key)`` (raises SweepError on a bad key),
- ``resources(key)`` — what the cell occupies besides one CPU: ``{"sitl": 1}`` for a cell that starts an autopilot
  SITL (the Ray executor asks for that custom resource; the local executor runs at most ``--sitl-slots`` at once),
- ``inputs(key) -> dict`` (optional) — what the cell needs from the driver's machine (another sweep's recorded
  gains): resolved by the driver before the cell is sent, so a cell on a cluster node needs no store there,
- ``run(key, inputs) -> dict`` with ``flights``, ``safety``, ``result``, ``timing`` (ksbo_bench.record), raising
  ksbo_bench.cell_errors.InfraError when the infrastructure, not the gains, failed.

Modules are imported when a cell runs, so a sweep of planar cells loads no SITL code.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any

from ksbo_bench.cell_errors import SweepError


@dataclass(frozen=True)
class Kind:
    name: str
    module: str
    required: tuple[str, ...]
    doc: str

    def _mod(self):
        return importlib.import_module(self.module)

    def check(self, key: dict[str, Any]) -> None:
        missing = [k for k in self.required if k not in key]
        if missing:
            raise SweepError(f"a {self.name} cell needs {', '.join(missing)} (declare them in [fixed] or [grid])")
        check = getattr(self._mod(), "check", None)
        if check:
            check(key)

    def resources(self, key: dict[str, Any]) -> dict[str, float]:
        fn = getattr(self._mod(), "resources", None)
        return fn(key) if fn else {}

    def inputs(self, key: dict[str, Any]) -> dict[str, Any]:
        fn = getattr(self._mod(), "inputs", None)
        return fn(key) if fn else {}

    def run(self, key: dict[str, Any], inputs: dict[str, Any] | None = None) -> dict[str, Any]:
        return self._mod().run(key, inputs or {})


KINDS = {k.name: k for k in (
    Kind("plant", "ksbo_bench.kinds.plant", ("plant", "method", "seed", "budget"),
         "safe BO in process on a planar plant or the JSBSim copter; the recommendation re-flown"),
    Kind("paper", "ksbo_bench.kinds.paper", ("setting", "method", "seed"),
         "the paper's comparison on the planar task: its prior, its budget, its re-flight"),
    Kind("campaign", "ksbo_bench.kinds.campaign", ("vehicle", "seed"),
         "a full `ksbo-mav tune` campaign on a fresh vehicle (ArduCopter / PX4 SITL, our JSBSim copter or planar "
         "vehicle over MAVLink), then named gains re-flown in turn on it"),
    Kind("flights", "ksbo_bench.kinds.flights", ("vehicle", "ways"),
         "fixed gain sets flown several ways on one fresh SITL, in turn: streamed, on board, by a separate client, "
         "the validation manoeuvres"),
    Kind("evaluation", "ksbo_bench.kinds.evaluate", ("what",),
         "one deterministic computation that is not a campaign (ksbo_bench.evaluations)"),
    Kind("fault", "ksbo_bench.kinds.fault", ("fault", "phase", "pilot"),
         "one case of the fault matrix on ArduCopter SITL: the link cut or the tuner killed at a phase of a short "
         "campaign, what the vehicle did, what continued it, the parameters against the snapshot"),
    Kind("wind", "ksbo_bench.kinds.wind", ("speed", "shape"),
         "a short campaign on ArduCopter SITL in a set wind: the wind the report infers against what the SITL blows"),
    Kind("timing", "ksbo_bench.kinds.timing", ("what",),
         "a pure timing: seconds of one named operation, best of repeats"),
)}
