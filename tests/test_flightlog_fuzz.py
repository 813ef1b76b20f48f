"""Bounded, seeded fuzz of the flight-log readers: logs of all three formats, mutated (truncated, bytes flipped,
garbage inserted, the head cut, emptied), must give either a result — one that names what it skipped when
garbage was inserted — or a non-zero exit with one line; never a traceback, never a hang."""

from __future__ import annotations

import json
import random
import signal
from pathlib import Path

import pytest

from flightlog_helpers import write_bin, write_other_tlog, write_ulg

from ksbo_mav.cli import main

DATA = Path(__file__).parent / "data" / "flightlog"
TIME_BOUND_S = 20  # per file; a reader that loops on damage would hit it
CASES = 30
MUTATIONS = ("truncate", "flip", "insert", "head", "empty")


@pytest.fixture(scope="module")
def sources(tmp_path_factory) -> dict[str, bytes]:
    d = tmp_path_factory.mktemp("fuzz-src")
    out = {"tlog": write_other_tlog(d / "a.tlog").read_bytes(), "bin": write_bin(d / "a.bin").read_bytes(),
           "ulg": write_ulg(d / "a.ulg").read_bytes()}
    for p in sorted(DATA.glob("*")) if DATA.is_dir() else []:  # our own recordings, when present
        if p.suffix.lower() in (".tlog", ".bin", ".ulg"):
            out[p.name] = p.read_bytes()
    return out


def mutate(data: bytes, kind: str, rng: random.Random) -> bytes:
    n = len(data)
    if kind == "truncate":
        return data[:rng.randrange(1, n)]
    if kind == "flip":
        b = bytearray(data)
        for _ in range(rng.randint(1, 20)):
            b[rng.randrange(n)] ^= 1 << rng.randrange(8)
        return bytes(b)
    if kind == "insert":
        i = rng.randrange(n // 4, n)
        return data[:i] + bytes(rng.randrange(256) for _ in range(rng.choice((1, 7, 64, 300)))) + data[i:]
    if kind == "head":
        return data[rng.randrange(1, 2048):]
    return b""


def _alarm(signum, frame):
    raise TimeoutError(f"a reader took more than {TIME_BOUND_S} s")


@pytest.mark.parametrize("case", range(CASES))
def test_mutated_log(tmp_path, capsys, sources, case):
    rng = random.Random(1000 + case)
    name = sorted(sources)[case % len(sources)]
    kind = MUTATIONS[(case // len(sources)) % len(MUTATIONS)] if case < 3 * len(MUTATIONS) else rng.choice(MUTATIONS)
    path = tmp_path / f"fuzz{case}.log"
    path.write_bytes(mutate(sources[name], kind, rng))
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(TIME_BOUND_S)
    try:
        rc = main(["score", str(path), "--partial", "--json"])  # any other exception fails the test: a traceback
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    out, err = capsys.readouterr()
    if rc == 0:
        result = json.loads(out)
        if kind == "insert":
            assert result["damaged_spans"] or result["warnings"], f"{name} {kind}: nothing said about the damage"
    else:
        assert rc == 2 and out == "" and err.startswith("error: ") and err.count("\n") == 1, (name, kind, err)
