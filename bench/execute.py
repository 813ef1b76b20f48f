"""Run one cell where it landed (a local worker process or a Ray worker): BLAS pinned to one thread, the kind's
code, the record made. The same function under either executor, so the same cell gives the same record."""

from __future__ import annotations

import os
import time
from typing import Any

from ksbo_bench import record
from ksbo_bench.cell_errors import CellError, InfraError
from ksbo_bench.kinds import KINDS
from ksbo_bench.sweep import Cell

#: Threads of the BLAS and OpenMP libraries in a cell: one, so that two runs of a cell do the same arithmetic in
#: the same order and the cells of one machine do not fight over its cores.
BLAS_THREADS = 1


def pin_blas() -> None:
    """One BLAS/OpenMP thread in this process (set before numpy loads where possible, then enforced)."""
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
        os.environ.setdefault(var, str(BLAS_THREADS))
    import scipy.linalg  # noqa: F401 - load every BLAS first: threadpool_limits only pins libraries already loaded
    from threadpoolctl import threadpool_limits

    threadpool_limits(BLAS_THREADS)


def run_cell(sweep: str, kind: str, key: dict[str, Any], executor: str, node: str = "",
             attempt: int = 1, inputs: dict[str, Any] | None = None) -> dict[str, Any]:
    """The record of one cell. InfraError passes through (the executor retries it); any other exception becomes
    CellError with the cell named."""
    pin_blas()
    cell = Cell(sweep, kind, key)
    started = record.now()
    t0 = time.perf_counter()
    try:
        out = KINDS[kind].run(key, inputs)
    except InfraError:
        raise
    except Exception as e:  # noqa: BLE001 - said with the cell's key; the run goes on with the other cells
        raise CellError(f"{cell.label()}: {type(e).__name__}: {e}") from e
    return record.make(cell, out, started, time.perf_counter() - t0, executor, node, attempt)
