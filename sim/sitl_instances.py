"""SITL instance numbers claimed machine-wide, so two pytest workers (or two test runs) never start autopilots on
the same ports.

An instance number decides every port of a SITL (ArduCopter N: TCP 5760/5762/5763+10N, UDP 5501+10N; PX4 N:
sends to UDP 14540+N, listens on 14580+N and 18570+N). A claim is an exclusive ``flock`` on
``$TMPDIR/ksbo-sitl-instances/KIND-N.lock``, held while that SITL runs: the kernel drops it when the process
ends, however it ends, so a crashed worker never leaves a number taken. A number whose client port is bound by
something else (an autopilot started by hand, another checkout's tests) is passed over too. PX4 sends its GCS link
to UDP 14550 for every instance; no test listens there.
"""

from __future__ import annotations

import fcntl
import itertools
import os
import tempfile
import time
from pathlib import Path

from ksbo_sim.sitl import Sitl, find_run_script, ports_taken, start_sitl

#: 1..9: PX4 instances from 10 up all send to one API port; instance 0 is left to an autopilot started by hand.
NUMBERS = range(1, 10)
CLAIM_DIR = Path(tempfile.gettempdir()) / "ksbo-sitl-instances"
#: How long a start waits for a number when every one is held (other workers' SITLs end within a test or two).
WAIT_S = 600.0

# Each process starts its search at a different number and moves on after every claim, so a number just released
# (its ports maybe still closing) is the last one this process tries again.
_turn = itertools.count(os.getpid() % len(NUMBERS))
_held: dict[int, Sitl | None] = {}  # lock fd -> the SITL started on its number (None while starting)


def release_stopped() -> None:
    for fd, sitl in list(_held.items()):
        if sitl is not None and not sitl.alive:
            release(fd)


def release(fd: int) -> None:
    """Give the number held by ``fd`` back (its SITL has stopped)."""
    if fd in _held:
        del _held[fd]
        os.close(fd)  # closing the only descriptor of the lock file drops the flock


def claim(kind: str) -> tuple[int, int]:
    """(instance number, lock fd): a number no other process on this machine holds for ``kind``."""
    release_stopped()
    CLAIM_DIR.mkdir(exist_ok=True)
    deadline = time.monotonic() + WAIT_S
    while True:
        first = next(_turn)
        for k in range(len(NUMBERS)):
            n = NUMBERS[(first + k) % len(NUMBERS)]
            fd = os.open(CLAIM_DIR / f"{kind}-{n}.lock", os.O_CREAT | os.O_RDWR, 0o666)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                continue
            if ports_taken(kind, n):
                os.close(fd)
                continue
            _held[fd] = None
            return n, fd
        if time.monotonic() > deadline:
            raise RuntimeError(f"no free {kind} SITL instance number in {NUMBERS} after {WAIT_S:g} s "
                               f"(held: {sorted(p.name for p in CLAIM_DIR.glob(f'{kind}-*.lock'))})")
        time.sleep(1.0)


def start_claimed(kind: str, speedup: float, **kw) -> Sitl:
    """A SITL of ``kind`` on a claimed instance number (the claim ends once it has stopped). SitlNotFound if
    there is none on this machine."""
    find_run_script(kind)
    n, fd = claim(kind)
    try:
        sitl = start_sitl(kind, instance=n, speedup=speedup, **kw)
    except BaseException:
        release(fd)
        raise
    _held[fd] = sitl
    return sitl

