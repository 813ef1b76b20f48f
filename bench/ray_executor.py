"""The Ray executor: one Ray task per cell, on this machine (a local Ray instance started for the run) or on a
cluster (``--ray-address``). Every cell asks for one CPU; a cell that starts a SITL also asks for one unit of the
custom resource ``sitl`` (the SITL slots a node declares: ``ray start --resources '{"sitl": 2}'``), so Ray sends it
only to a node with a free slot, and the cell claims a SITL instance number and its ports on that node
(ksbo_sim.sitl_instances: a machine-wide flock). The record comes back to the driver as the task's return value;
only the driver writes the store.

Retries: a worker process or node that dies is Ray's to retry (``max_retries``); a cell that raised InfraError
(a SITL that did not boot) is submitted again by this executor, up to ``retries`` more times; any other failure is
the cell's end.
"""

from __future__ import annotations

import os
import signal
import socket
import sys
from pathlib import Path
from typing import Any, Iterator

from ksbo_bench.cell_errors import InfraError
from ksbo_bench.execute import run_cell
from ksbo_bench.kinds import KINDS
from ksbo_bench.sweep import Cell

#: The custom resource a SITL cell asks for: one per SITL that may run at once on a node.
SITL_RESOURCE = "sitl"
#: Tries at starting a local Ray instance: its raylet has 30 s to register, and waits for the dashboard agent (a
#: Python process) to write its ports first, which a loaded machine misses (measured here at load 21-42: every
#: try of several runs, with or without Ray's daemons at a raised priority).
START_TRIES = 3


def _descendants(pid: int) -> list[int]:
    """Every process below ``pid`` (Linux /proc)."""
    children: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        children.setdefault(int(fields[1]), []).append(int(stat.parent.name))
    out, todo = [], [pid]
    while todo:
        for c in children.get(todo.pop(), []):
            out.append(c)
            todo.append(c)
    return out


def _remote_cell(sweep: str, kind: str, key: dict[str, Any], attempt: int, inputs: dict[str, Any]) -> dict[str, Any]:
    import ray

    node = f"{socket.gethostname()}/{ray.get_runtime_context().get_node_id()[:8]}"
    return run_cell(sweep, kind, key, "ray", node=node, attempt=attempt, inputs=inputs)


class RayExecutor:
    name = "ray"

    def __init__(self, address: str | None = None, jobs: int | None = None, sitl_slots: int = 1,
                 retries: int = 2):
        self.address, self.jobs, self.sitl_slots, self.retries = address, jobs, sitl_slots, retries
        self._started = False
        self._remote = None

    def start(self) -> None:
        try:
            import ray
        except ImportError:
            raise RuntimeError("the Ray executor needs Ray: pip install 'ksbo-mav[ray]'") from None
        if ray.is_initialized():
            return
        # the workers get this process's environment on a local instance; BLAS threads pinned in every worker
        env = {"env_vars": {v: "1" for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")}}
        for attempt in range(1, START_TRIES + 1):
            before = set(_descendants(os.getpid()))
            try:
                if self.address:
                    ray.init(address=self.address, runtime_env=env, log_to_driver=False)
                else:
                    ray.init(num_cpus=self.jobs or os.cpu_count(), resources={SITL_RESOURCE: self.sitl_slots},
                             include_dashboard=False, object_store_memory=200 * 2**20, runtime_env=env,
                             log_to_driver=False)
                    self._started = True
                return
            except Exception as e:  # noqa: BLE001 - Ray raises a bare Exception when its raylet is slow to register
                ray.shutdown()
                for pid in set(_descendants(os.getpid())) - before:  # what the failed start left (ray.shutdown
                    try:  # does not stop a node that never registered): its GCS, dashboard, monitors
                        os.kill(pid, signal.SIGKILL)
                    except OSError:
                        pass
                if attempt == START_TRIES:
                    raise RuntimeError(f"Ray did not start ({START_TRIES} tries): {e}") from None
                print(f"Ray did not start ({e}); trying again", file=sys.stderr)

    def describe(self) -> str:
        import ray

        nodes = [n for n in ray.nodes() if n.get("Alive")]
        cpus = sum(n["Resources"].get("CPU", 0) for n in nodes)
        slots = sum(n["Resources"].get(SITL_RESOURCE, 0) for n in nodes)
        return f"ray, {len(nodes)} node(s), {cpus:g} CPUs, {slots:g} SITL slot(s)"

    def stop(self) -> None:
        import ray

        if self._started:
            ray.shutdown()

    def _submit(self, cell: Cell, attempt: int):
        import ray

        res = KINDS[cell.kind].resources(cell.key)
        if self._remote is None:
            self._remote = ray.remote(_remote_cell)
        fn = self._remote.options(num_cpus=1, resources=res or None, max_retries=3,
                                              name=f"{cell.sweep}: {cell.label(80)}")
        return fn.remote(cell.sweep, cell.kind, cell.key, attempt, cell.inputs)

    def map(self, cells: list[Cell]) -> Iterator[tuple[Cell, "dict[str, Any] | BaseException", int]]:
        import ray

        self.start()
        try:
            sitl = [c for c in cells if KINDS[c.kind].resources(c.key).get(SITL_RESOURCE)]
            if sitl and not ray.cluster_resources().get(SITL_RESOURCE):
                raise RuntimeError(f"{len(sitl)} SITL cells but no node declares SITL slots: start each node with "
                                   "ray start --resources '{\"sitl\": N}' (or --sitl-slots N without --ray-address)")
            running = {self._submit(c, 1): (c, 1) for c in cells}
            while running:
                done, _ = ray.wait(list(running), num_returns=1)
                ref = done[0]
                cell, attempt = running.pop(ref)
                try:
                    yield cell, ray.get(ref), attempt
                except ray.exceptions.RayTaskError as e:
                    cause = e.cause if isinstance(getattr(e, "cause", None), BaseException) else e
                    if isinstance(cause, InfraError) and attempt <= self.retries:
                        running[self._submit(cell, attempt + 1)] = (cell, attempt + 1)
                    else:
                        yield cell, cause, attempt
                except ray.exceptions.RayError as e:  # a node lost past Ray's own retries, a worker killed
                    yield cell, e, attempt
        finally:
            self.stop()
