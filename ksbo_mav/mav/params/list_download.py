"""The full parameter download over the PARAM protocol, made to finish on a slow, lossy link.

PARAM_REQUEST_LIST makes the autopilot stream every PARAM_VALUE once; over a radio some are lost, and the missing
indices are asked for again by PARAM_REQUEST_READ once the stream goes quiet (as MAVProxy and QGroundControl do).
Two things make that finish on a thin link:

* The download gives up only after ``stall_s`` seconds without a *new* index — a budget of time without progress,
  not a count of passes: a slow link that keeps delivering is never abandoned, a dead one is within seconds.
* Re-requests are paced like a sliding window (TCP's additive increase, multiplicative decrease): at most
  ``window`` indices are outstanding (5–50); each answer widens it a little, a request unanswered after three
  smoothed round trips is counted lost, asked again, and narrows it ×0.7. A radio's small buffer then neither
  overflows from a burst of requests nor idles while one answer is awaited at a time.

Duplicates and out-of-order PARAM_VALUEs are harmless (the table is keyed by index); answers to reads by name
(index 65535) are ignored.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable

from ksbo_mav.mav.link import Link

MIN_BATCH, MAX_BATCH = 5, 50


@dataclass
class ParamListing:
    """What a download got: ``values`` {index: PARAM_VALUE message}, ``count`` (param_count), and how."""

    values: dict[int, Any] = field(default_factory=dict)
    count: int = 0
    seconds: float = 0.0
    requests: int = 0  # PARAM_REQUEST_READ sent for missing indices
    duplicates: int = 0
    path: str = "PARAM protocol"
    nbytes: int = 0  # the parameter file's size (MAVLink FTP)

    @property
    def complete(self) -> bool:
        return self.count > 0 and len(self.values) >= self.count


def download_list(link: Link, stall_s: float = 15.0, quiet_s: float = 0.5,
                  progress: Callable[[int, int], None] | None = None, progress_every_s: float = 2.0
                  ) -> ParamListing:
    """Every PARAM_VALUE the vehicle on ``link`` holds (see the module docstring); ``progress(got, count)`` is
    called every ``progress_every_s`` seconds while it runs. The result may be incomplete: check ``complete``."""
    res = ParamListing()
    t0 = time.monotonic()
    last_new = last_rx = last_report = t0

    def on_msg(msg: Any) -> None:
        nonlocal last_new, last_rx
        if msg.get_type() != "PARAM_VALUE" or not link.is_vehicle(msg):
            return
        last_rx = time.monotonic()
        res.count = max(res.count, int(msg.param_count))
        i = int(msg.param_index)
        if not 0 <= i < 65535:
            return
        if i in res.values:
            res.duplicates += 1
            return
        res.values[i] = msg
        last_new = last_rx

    def request_list() -> None:
        link.send(link.mav.param_request_list_encode(link.target_system, link.target_component))

    link.handlers.append(on_msg)
    window, srtt = float(2 * MIN_BATCH), quiet_s
    outstanding: dict[int, float] = {}  # index -> when it was requested
    try:
        request_list()
        while not res.complete:
            link.pump(0.02)
            now = time.monotonic()
            if progress is not None and now - last_report >= progress_every_s:
                progress(len(res.values), res.count)
                last_report = now
            if now - last_new > stall_s:
                break
            for i in [i for i in outstanding if i in res.values]:  # answered: the round trip, a larger window
                srtt = 0.8 * srtt + 0.2 * (now - outstanding.pop(i))
                window = min(MAX_BATCH, window + 1.0 / max(window, 1.0) * MIN_BATCH)
            if not res.count:
                if now - last_rx >= quiet_s:  # nothing yet: the request itself may have been lost
                    request_list()
                    last_rx = now
                continue
            if not res.requests and now - last_rx < quiet_s:
                continue  # the first stream is still coming
            timeout = max(0.2, 3.0 * srtt)
            lost = [i for i, t in outstanding.items() if now - t > timeout]
            if lost:  # lost on the way, or the link is saturated: fewer in flight
                window = max(float(MIN_BATCH), window * 0.7)
                for i in lost:
                    del outstanding[i]
            missing = (i for i in range(res.count) if i not in res.values and i not in outstanding)
            for i in missing:
                if len(outstanding) >= int(window):
                    break
                link.send(link.mav.param_request_read_encode(link.target_system, link.target_component, b"", i))
                outstanding[i] = now
                res.requests += 1
    finally:
        link.handlers.remove(on_msg)
    res.seconds = time.monotonic() - t0
    return res
