"""The link check of a campaign: before the baseline is read or anything is armed, measure what the link delivers
at the mission's stream rates (ksbo_mav.mav.linkcheck), refuse in one line when a trial could not be flown over it,
and keep the figures in the campaign directory (``link.json``, one entry per start or resume) for the report."""

from __future__ import annotations

import json
import time
from collections.abc import Callable

from ksbo_mav.campaign.layout import CampaignDir
from ksbo_mav.errors import PreflightError
from ksbo_mav.mav.snapshot import fsync_write
from ksbo_mav.mav.linkcheck import LinkFigures, judged, judged_stream, measure, verdict
from ksbo_mav.mav.vehicle import Vehicle


def check_link(v: Vehicle, log: Callable[[str], None], seconds: float = 3.0) -> LinkFigures:
    """Request the mission's streams, measure the link for ``seconds``, say what it delivers; PreflightError (one
    line naming the measured and needed rates) when a trial could not be flown over it."""
    v.setup_streams()
    fig = measure(v.link, seconds)
    why = verdict(fig, float(v.mission.rate_hz))
    if why:  # once more: a burst (the vehicle's parameter download, a ground station joining) may have passed
        fig = measure(v.link, 2 * seconds)
        why = verdict(fig, float(v.mission.rate_hz))
    log(f"link: {fig.describe()}" + (f" (the mission needs {judged_stream(fig)} at {v.mission.rate_hz} Hz)"
                                     if judged(fig) else ""))
    if why:
        raise PreflightError(why)
    return fig


def record_link(d: CampaignDir, fig: LinkFigures) -> None:
    """Append the figures to ``link.json`` (a list: the campaign's start and each resume)."""
    path = d.root / "link.json"
    try:
        old = json.loads(path.read_text()) if path.is_file() else []
    except (OSError, ValueError):
        old = []
    fsync_write(path, json.dumps([*old, {"at": time.strftime("%Y-%m-%dT%H:%M:%S"), **fig.to_dict()}], indent=1))
