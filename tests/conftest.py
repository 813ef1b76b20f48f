import os

# MAVLink 2 framing for every pymavlink import in the test process (must precede `import pymavlink.mavutil`).
os.environ.setdefault("MAVLINK20", "1")
# Parameter sets the tool caches (PX4's _HASH_CHECK) go to a folder of this test session, never the user's home.
os.environ.setdefault("KSBO_MAV_CACHE_DIR", __import__("tempfile").mkdtemp(prefix="ksbo-param-cache-"))


# --- real autopilots (../shared/sitl, or $KSBO_ARDUPILOT_SITL / $KSBO_PX4_SITL) -------------------------------
import itertools  # noqa: E402

import pytest  # noqa: E402

from ksbo_sim.sitl import SitlNotFound, find_run_script, start_sitl  # noqa: E402

# Each SITL fixture gets its own instance number (1..9: PX4 instances >= 10 all send to one port), so a SITL
# still shutting down never shares ports with the next one; the start depends on the process id, so two test runs
# on one machine rarely pick the same ports.
_instances = itertools.count(os.getpid() % 9)


def sitl_or_skip(kind: str, speedup: float, **kw):
    """Start a SITL of ``kind`` on a fresh instance number, or skip the test with the reason it is missing."""
    try:
        find_run_script(kind)
    except SitlNotFound as exc:
        pytest.skip(str(exc))
    return start_sitl(kind, instance=1 + next(_instances) % 9, speedup=speedup, **kw)


@pytest.fixture(scope="module")
def ardupilot_sitl():
    """ArduCopter SITL at 10x, fresh parameters, one per test module (stopped by PID at the end)."""
    sitl = sitl_or_skip("ardupilot", 10)
    yield sitl
    sitl.stop()


@pytest.fixture(scope="module")
def px4_sitl():
    """PX4 SITL (SIH quad) at 5x, fresh parameters, one per test module (stopped by PID at the end)."""
    sitl = sitl_or_skip("px4", 5)
    yield sitl
    sitl.stop()
