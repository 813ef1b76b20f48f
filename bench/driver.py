"""The driver of a run: the sweep's cells less those in its store, handed to an executor, each record appended to
the store as it comes back, progress said on stderr (one line per finished cell: done/total, the cell, its figures,
its wall time, the node, the estimated time left)."""

from __future__ import annotations

import json
import sys
import time
from dataclasses import dataclass, field
from typing import Any, TextIO

from ksbo_bench.cell_errors import InfraError, NotYet
from ksbo_bench.kinds import KINDS
from ksbo_bench.store import Store
from ksbo_bench.sweep import Cell, Sweep, SweepError, varying


@dataclass
class Summary:
    total: int = 0
    skipped: int = 0
    ran: int = 0
    failed: list[str] = field(default_factory=list)  # cells that gave no record (infrastructure, the cell's code)
    wall_s: float = 0.0


def headline(rec: dict[str, Any]) -> str:
    """A record's figures for the progress line."""
    r, s = rec.get("result", {}), rec.get("safety", {})
    bits = [f"{k} {r[k]:+.3f}" for k in ("EP", "cut", "share_of_long") if isinstance(r.get(k), (int, float))]
    secs = rec.get("timing", {}).get("seconds") if rec.get("kind") == "timing" else r.get("seconds")
    if isinstance(secs, (int, float)):
        bits.append(f"{secs * 1e3:.3g} ms")
    bits += [f"{k} {s[k]}" for k in ("crashed", "aborted", "interrupted", "unsafe") if s.get(k)]
    if rec.get("status") != "ok":
        bits.insert(0, rec.get("status", "?").upper())
    return ", ".join(bits)


def pending(sweep: Sweep, store: Store, seeds: list[int] | None = None,
            where: dict[str, Any] | None = None) -> tuple[list[Cell], int]:
    """(cells still to run, cells already stored) of ``sweep`` (only those matching ``where``, if given)."""
    cells = sweep.cells(seeds)
    for name, value in (where or {}).items():
        having = [c for c in cells if name in c.key]
        if not having:
            names = sorted({k for c in cells for k in c.key})
            raise SweepError(f"--only {name}={value}: the sweep's cells have no {name!r} "
                             f"(they have {', '.join(names)})")
        cells = [c for c in having if value in (_spelled(c.key[name]), str(c.key[name]))]
        if not cells:
            values = sorted({_spelled(c.key[name]) for c in having})
            raise SweepError(f"--only {name}={value}: no cell has it; {name} takes {', '.join(values)}")
    done = store.done()
    todo = [c for c in cells if c.id not in done]
    return todo, len(cells) - len(todo)


def _spelled(value: Any) -> str:
    """A key value as the sweep file writes it (TOML: ``true``, ``2.5``, ``nominal``)."""
    return json.dumps(value) if isinstance(value, bool) else str(value)


def resolve(cells: list[Cell]) -> tuple[list[Cell], list[tuple[Cell, NotYet]]]:
    """(cells with their inputs resolved here, on the driver's machine; cells whose input is a record not stored
    yet, with what each waits for)."""
    ready, waiting = [], []
    for c in cells:
        try:
            ready.append(Cell(c.sweep, c.kind, c.key, KINDS[c.kind].inputs(c.key)))
        except NotYet as e:
            waiting.append((c, e))
    return ready, waiting


def run(sweep: Sweep, executor, store: Store, seeds: list[int] | None = None, where: dict[str, Any] | None = None,
        out: TextIO = sys.stderr) -> Summary:
    if sweep.archive:
        print(f"{sweep.name}: an archive of records (archive = true): nothing to run", file=out)
        return Summary()
    todo, skipped = pending(sweep, store, seeds, where)
    summ = Summary(total=len(todo) + skipped, skipped=skipped)
    sitl = sum(1 for c in todo if KINDS[c.kind].resources(c.key).get("sitl"))
    print(f"{sweep.name}: {summ.total} cells, {skipped} already in {store.path}, {len(todo)} to run"
          + (f" ({sitl} on a SITL)" if sitl else ""), file=out, flush=True)
    if not todo:
        return summ
    names = varying(todo)
    t0 = time.monotonic()
    first, n, left = True, 0, todo
    while left:  # in waves: a cell whose input is another pending cell's record waits for that cell
        ready, waiting = resolve(left)
        if not ready:
            if not n:
                raise waiting[0][1]  # nothing can run at all: a sweep that needs another's records first
            summ.failed += [f"{c.id}: its input: {e}" for c, e in waiting]
            break
        left = [c for c, _ in waiting]
        for cell, res, attempts in executor.map(ready):
            if first:
                print(f"  executor: {executor.describe()}", file=out, flush=True)
                first = False
            n += 1
            eta = (time.monotonic() - t0) / n * (len(todo) - n)
            head = f"[{n + skipped:{len(str(summ.total))}d}/{summ.total}] {cell.label(70, names)}"
            if isinstance(res, dict):
                store.append(res)
                summ.ran += 1
                node = res["run"]["node"] if res["run"]["executor"] == "ray" else ""
                print(f"{head}: {headline(res)} ({res['timing']['wall_s']:.1f} s{', ' + node if node else ''}"
                      f"{f', attempt {attempts}' if attempts > 1 else ''}; left ~{eta / 60:.1f} min)", file=out,
                      flush=True)
            else:
                why = "infrastructure" if isinstance(res, InfraError) else type(res).__name__
                summ.failed.append(f"{cell.id}: {why}: {res}")
                print(f"{head}: NO RECORD after {attempts} attempt(s) ({why}: {str(res)[:200]})", file=out,
                      flush=True)
    summ.wall_s = time.monotonic() - t0
    print(f"{sweep.name}: {summ.ran} records written in {summ.wall_s / 60:.1f} min"
          + (f", {len(summ.failed)} cells without a record (run again to retry them)" if summ.failed else ""),
          file=out, flush=True)
    return summ
