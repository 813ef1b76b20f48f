import os

# MAVLink 2 framing for every pymavlink import in the test process (must precede `import pymavlink.mavutil`).
os.environ.setdefault("MAVLINK20", "1")
# Parameter sets the tool caches (PX4's _HASH_CHECK) go to a folder of this test process, never the user's home;
# each pytest-xdist worker gets its own (a worker inherits the folder of the process that started it).
if "PYTEST_XDIST_WORKER" in os.environ or "KSBO_MAV_CACHE_DIR" not in os.environ:
    os.environ["KSBO_MAV_CACHE_DIR"] = __import__("tempfile").mkdtemp(prefix="ksbo-param-cache-")


# --- real autopilots (../shared/sitl, or $KSBO_ARDUPILOT_SITL / $KSBO_PX4_SITL) -------------------------------
import pytest  # noqa: E402

from ksbo_sim.sitl import SitlNotFound  # noqa: E402
from ksbo_sim.sitl_instances import release_stopped, start_claimed  # noqa: E402
from sitl_scheduling import SITL_GROUP, OneSitlAtATime  # noqa: E402


def sitl_or_skip(kind: str, speedup: float, **kw):
    """Start a SITL of ``kind`` on an instance number no other test process holds (``sitl_instances``), or skip
    the test with the reason it is missing."""
    try:
        return start_claimed(kind, speedup, **kw)
    except SitlNotFound as exc:
        pytest.skip(str(exc))


@pytest.fixture(scope="module")
def ardupilot_sitl():
    """ArduCopter SITL at 10x, fresh parameters, one per test module (stopped by PID at the end)."""
    sitl = sitl_or_skip("ardupilot", 10)
    yield sitl
    sitl.stop()
    release_stopped()


@pytest.fixture(scope="module")
def px4_sitl():
    """PX4 SITL (SIH quad) at 5x, fresh parameters, one per test module (stopped by PID at the end)."""
    sitl = sitl_or_skip("px4", 5)
    yield sitl
    sitl.stop()
    release_stopped()


# --- side by side (pytest-xdist `--dist loadgroup --no-loadscope-reorder`, set in pyproject.toml) --------------
def _shared_fixtures(item: pytest.Item) -> list[str]:
    """This suite's fixtures that ``item`` uses and that live longer than one test (an autopilot, a campaign)."""
    info = getattr(item, "_fixtureinfo", None)
    if info is None:
        return []
    return sorted(name for name, defs in info.name2fixturedefs.items()
                  if defs and defs[-1].scope != "function" and defs[-1].baseid)


def _kind(items: list[pytest.Item]) -> int:
    """-1: runs alone, 0: flies a real autopilot, 1: talks to a simulator process (often in real time),
    2: in-process."""
    marks = {m.name for item in items for m in item.iter_markers()}
    return -1 if "solo" in marks else 0 if "sitl" in marks else 1 if "network" in marks else 2


@pytest.hookimpl(tryfirst=True)  # before xdist's own hook, which appends the group to each test's id
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Tests that share a module-scoped fixture run on one worker (one autopilot start, one campaign); every other
    test is scheduled alone. Modules that fly autopilots go first and in-process ones last, so the long tests start
    early and the short ones fill the gaps at the end instead of one worker flying alone; `solo` ones first of
    all, so the other worker waits for them once, at the start. The groups of the tests that fly an autopilot are
    named ``SITL_GROUP...``: one worker at a time flies them (:func:`pytest_xdist_make_scheduler`)."""
    modules: dict[str, list[pytest.Item]] = {}
    for item in items:
        modules.setdefault(str(item.path), []).append(item)
        shared = _shared_fixtures(item)
        group = f"{item.path.name}:{'+'.join(shared)}" if shared else None
        if item.get_closest_marker("sitl") is not None:  # named so, even alone (xdist reads "]" after "@" as a
            group = SITL_GROUP + (group or item.nodeid.replace("[", "(").replace("]", ")"))  # parameter's end)
        if group:
            item.add_marker(pytest.mark.xdist_group(group))
    kind = {path: _kind(its) for path, its in modules.items()}
    items.sort(key=lambda item: kind[str(item.path)])


@pytest.hookimpl(tryfirst=True)  # before xdist's own
def pytest_xdist_make_scheduler(config: pytest.Config, log):
    """``--dist loadgroup`` with at most one worker flying a SITL at a time (:mod:`sitl_scheduling`)."""
    return OneSitlAtATime(config, log) if config.getvalue("dist") == "loadgroup" else None


@pytest.hookimpl(hookwrapper=True, tryfirst=True)  # outside pytest-timeout: waiting for the other worker is free
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None):
    """Under pytest-xdist a test marked `solo` (a client that must keep up with a fast SITL) runs while no other
    test of this run does: it waits for the running ones to end, and the next ones wait for it. A flock pair in
    the folder the run's workers share (a gate, so that the solo test is not starved, and the lock itself)."""
    if "PYTEST_XDIST_WORKER" not in os.environ:
        yield
        return
    import fcntl

    folder = os.path.dirname(item.config.option.basetemp)  # xdist gives each worker <the run's basetemp>/popen-gwN
    gate, lock = (os.open(os.path.join(folder, name), os.O_CREAT | os.O_RDWR, 0o644) for name in ("solo.gate",
                                                                                                   "solo.lock"))
    solo = item.get_closest_marker("solo") is not None
    try:
        fcntl.flock(gate, fcntl.LOCK_EX)
        fcntl.flock(lock, fcntl.LOCK_EX if solo else fcntl.LOCK_SH)
        if not solo:
            fcntl.flock(gate, fcntl.LOCK_UN)
        yield
    finally:
        os.close(lock)
        os.close(gate)
