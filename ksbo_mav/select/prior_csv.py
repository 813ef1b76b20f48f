"""Prior data files: a CSV with one column per gain (the profile's names, physical units) and a ``P`` column."""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ksbo_mav.errors import InputError

TARGET = "P"


def write_prior_csv(path: str | Path, names: Sequence[str], X: NDArray[np.float64], P: NDArray[np.float64]) -> Path:
    """Write ``X`` (``(n, D)`` physical gains, columns ``names``) and ``P`` (``(n,)``) with full precision."""
    path = Path(path)
    try:
        with path.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(list(names) + [TARGET])
            for row, p in zip(np.asarray(X, dtype=float), np.asarray(P, dtype=float)):
                w.writerow([repr(float(v)) for v in row] + [repr(float(p))])
    except OSError as exc:
        raise InputError(f"cannot write {path}: {exc.strerror or exc}") from None
    return path


def read_prior_csv(path: str | Path, names: Sequence[str]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Read and validate a prior CSV.

    Columns are matched by header name (any order; other columns are ignored). Every used cell must be a finite
    number, and there must be more rows than used columns (``D + 1``), so the data can rank ``D``-D kernels.

    Args:
        path: CSV file.
        names: the ``D`` gain column names expected (the profile's ``names``).

    Returns:
        ``X`` of shape ``(n, D)`` (physical units, in ``names`` order) and ``P`` of shape ``(n,)``.

    Raises:
        InputError: with a one-line reason (missing file/column, non-numeric or non-finite cell, too few rows).
    """
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8-sig") as fh:
            rows = [r for r in csv.reader(fh) if any(c.strip() for c in r)]
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read ({exc})") from None
    except csv.Error as exc:
        raise InputError(f"{path}: not a valid CSV file ({exc})") from None
    if not rows:
        raise InputError(f"{path}: empty file (expected a header {', '.join(list(names) + [TARGET])})")
    header = [h.strip() for h in rows[0]]
    wanted = list(names) + [TARGET]
    missing = [c for c in wanted if c not in header]
    if missing:
        raise InputError(f"{path}: missing column(s) {', '.join(missing)} (expected {', '.join(wanted)})")
    dup = sorted({c for c in wanted if header.count(c) > 1})
    if dup:
        raise InputError(f"{path}: duplicate column(s) {', '.join(dup)}")
    cols = [header.index(c) for c in wanted]
    data = np.empty((len(rows) - 1, len(wanted)))
    for i, row in enumerate(rows[1:]):
        line = i + 2
        if len(row) != len(header):
            raise InputError(f"{path} line {line}: {len(row)} fields, header has {len(header)}")
        for j, c in enumerate(cols):
            cell = row[c].strip()
            try:
                v = float(cell)
            except ValueError:
                raise InputError(f"{path} line {line}, column {wanted[j]}: {cell!r} is not a number") from None
            if not math.isfinite(v):
                raise InputError(f"{path} line {line}, column {wanted[j]}: {cell!r} is not finite (NaN/inf)")
            data[i, j] = v
    if data.shape[0] < len(wanted):
        raise InputError(f"{path}: {data.shape[0]} data row(s) but {len(wanted)} columns; "
                         f"need at least {len(wanted)} rows")
    return data[:, :-1], data[:, -1]
