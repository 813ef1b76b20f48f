"""Port arithmetic of the SITL launcher (no SITL is started)."""

from __future__ import annotations

import pytest

from ksbo_sim.sitl import start_sitl


def test_a_px4_instance_from_10_up_is_refused_before_anything_starts() -> None:
    """PX4's startup script sends the API link of every instance from 10 up to port 14549, where a client
    listening on 14540+N hears nothing: the launcher waited 60 s for a heartbeat and failed without saying why."""
    with pytest.raises(ValueError, match=r"PX4 SITL instance 12: use 0\.\.9"):
        start_sitl("px4", instance=12)
