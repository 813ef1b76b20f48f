"""Score any flight log: ArduPilot DataFlash ``.BIN``, PX4 ``.ulg`` and any ground station's ``.tlog``.

``read_log(path)`` detects the format by content and returns a :class:`FlightLog` (position, the autopilot's
own target, received setpoints, modes, trial markers — one vehicle clock); ``analyse(log, mission)`` finds the
segments where the vehicle tracked position targets and scores each (per lap for the profile's figure-8).
``score_file`` does both for the CLI (``ksbo-mav score``, ``ksbo-mav compare``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ksbo_mav.flightlog.analysis import (analyse, default_profile, find_segments, recognise_figure8,
                                         recognise_figure8s)
from ksbo_mav.flightlog.detect import detect_format
from ksbo_mav.flightlog.model import FlightLog, Track
from ksbo_mav.flightlog.readers import read_log


def score_file(path: str | Path, profile: str | None = None, partial: bool = False, segment: int | None = None,
               rms_ref: float | None = None) -> tuple[dict[str, Any], FlightLog, Any]:
    """(analysis dict, the log, the mission) of one file; the profile defaults to the log's autopilot's."""
    from ksbo_mav.mav.mission import Mission
    from ksbo_mav.profiles import load_profile

    log = read_log(path, partial=partial)
    name = profile or default_profile(log)
    prof = load_profile(name)
    mission = Mission.from_profile(prof)
    return analyse(log, mission, prof.name, partial=partial, only=segment, rms_ref=rms_ref), log, mission


__all__ = ["FlightLog", "Track", "analyse", "detect_format", "find_segments", "read_log", "recognise_figure8",
           "recognise_figure8s", "score_file"]
