"""The local executor: this machine's processes. ``jobs`` worker processes (spawned, each with BLAS pinned to one
thread), at most ``sitl_slots`` cells that start a SITL in flight at once; a cell that failed for the
infrastructure is submitted again, up to ``retries`` more times."""

from __future__ import annotations

import multiprocessing
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from typing import Any, Iterator

from ksbo_bench.cell_errors import InfraError
from ksbo_bench.execute import pin_blas, run_cell
from ksbo_bench.kinds import KINDS
from ksbo_bench.sweep import Cell


def _worker_init() -> None:
    """A worker process: BLAS pinned; it ends with the driver (Linux: a parent-death signal), and SIGTERM unwinds
    it like an exception, so a cell's SITL or simulator is stopped by its own ``finally``, never left running."""
    import ctypes
    import signal
    import sys

    pin_blas()
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not Linux: the pool's own shutdown still ends the workers
        pass


Outcome = tuple[Cell, "dict[str, Any] | BaseException", int]


class LocalExecutor:
    name = "local"

    def __init__(self, jobs: int = 1, sitl_slots: int = 1, retries: int = 2):
        self.jobs, self.sitl_slots, self.retries = max(1, jobs), max(0, sitl_slots), retries

    def describe(self) -> str:
        return f"local, {self.jobs} process{'es' if self.jobs > 1 else ''}, {self.sitl_slots} SITL slot(s)"

    def map(self, cells: list[Cell]) -> Iterator[Outcome]:
        """(cell, record or the exception it ended with, attempts) as each cell ends."""
        queue = list(cells)
        running: dict[Future, tuple[Cell, int]] = {}
        ctx = multiprocessing.get_context("spawn")  # a fresh interpreter: no thread or BLAS state inherited
        with ProcessPoolExecutor(self.jobs, mp_context=ctx, initializer=_worker_init) as pool:
            while queue or running:
                sitl_busy = sum(1 for c, _ in running.values() if KINDS[c.kind].resources(c.key).get("sitl"))
                for cell in list(queue):
                    if len(running) >= self.jobs:
                        break
                    needs_sitl = KINDS[cell.kind].resources(cell.key).get("sitl", 0)
                    if needs_sitl and (sitl_busy >= self.sitl_slots):
                        continue
                    queue.remove(cell)
                    sitl_busy += bool(needs_sitl)
                    running[self._submit(pool, cell, 1)] = (cell, 1)
                if not running:
                    raise RuntimeError("SITL cells but --sitl-slots 0: nothing can run them")
                done, _ = wait(running, return_when=FIRST_COMPLETED)
                for fut in done:
                    cell, attempt = running.pop(fut)
                    try:
                        yield cell, fut.result(), attempt
                    except InfraError as e:
                        if attempt <= self.retries:
                            running[self._submit(pool, cell, attempt + 1)] = (cell, attempt + 1)
                        else:
                            yield cell, e, attempt
                    except Exception as e:  # noqa: BLE001 - CellError and the like: the cell's end, said
                        yield cell, e, attempt

    @staticmethod
    def _submit(pool: ProcessPoolExecutor, cell: Cell, attempt: int) -> Future:
        return pool.submit(run_cell, cell.sweep, cell.kind, cell.key, "local", "", attempt, cell.inputs)
