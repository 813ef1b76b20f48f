"""A sweep's store: a directory holding ``records.jsonl``, one record (ksbo_bench.record) per line, appended by the
runner's driver as cells finish (the executors hand records back; no worker writes here). A cell whose key has an
``ok`` or ``failed`` record is done: a run skips it, so an interrupted sweep resumes where it stopped."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Iterator

from ksbo_bench.sweep import SweepError, key_id

FILE = "records.jsonl"


class Store:
    def __init__(self, directory: str | Path):
        self.dir = Path(directory)
        self.path = self.dir / FILE

    def __iter__(self) -> Iterator[dict[str, Any]]:
        if not self.path.is_file():
            return
        for n, line in enumerate(self.path.read_text().splitlines(), 1):
            if not line.strip():
                continue
            try:
                rec = json.loads(line)
            except json.JSONDecodeError as e:
                raise SweepError(f"{self.path}:{n} is not a JSON record ({e.msg})") from None
            if not isinstance(rec, dict) or "key" not in rec:
                raise SweepError(f"{self.path}:{n} is not a record (no key)")
            yield rec

    def records(self) -> list[dict[str, Any]]:
        return list(self)

    def done(self) -> set[str]:
        """Key ids of the cells that have a record."""
        return {key_id(r["key"]) for r in self}

    def append(self, rec: dict[str, Any]) -> None:
        self.dir.mkdir(parents=True, exist_ok=True)
        with open(self.path, "a") as fh:
            fh.write(json.dumps(rec, sort_keys=False) + "\n")
