"""Port arithmetic of the SITL launcher, and instances whose ports are taken refused (no SITL is started)."""

from __future__ import annotations

import pytest

from ksbo_sim.sitl import start_sitl


def test_a_px4_instance_from_10_up_is_refused_before_anything_starts() -> None:
    """PX4's startup script sends the API link of every instance from 10 up to port 14549, where a client
    listening on 14540+N hears nothing: the launcher waited 60 s for a heartbeat and failed without saying why."""
    with pytest.raises(ValueError, match=r"PX4 SITL instance 12: use 0\.\.9"):
        start_sitl("px4", instance=12)



def _hold(kind: str, port: int):
    """A socket holding ``port`` as a running autopilot (ArduCopter: a TCP listener) or its client (PX4: UDP)."""
    import socket

    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM if kind == "ardupilot" else socket.SOCK_DGRAM)
    try:
        s.bind(("127.0.0.1", port))
    except OSError:
        s.close()
        return None
    if kind == "ardupilot":
        s.listen(1)
    return s


@pytest.mark.parametrize("kind, port_of", [("ardupilot", lambda n: 5760 + 10 * n), ("px4", lambda n: 14540 + n)])
def test_an_instance_whose_ports_are_held_is_refused_before_anything_starts(kind, port_of, tmp_path) -> None:
    """A second autopilot on an instance number another process uses would die at once while the launcher took the
    first one's heartbeat for its own: a benchmark would then fly a test's vehicle (or the other way round)."""
    from ksbo_sim.sitl import SitlNotFound, find_run_script

    try:
        find_run_script(kind)
    except SitlNotFound as exc:
        pytest.skip(str(exc))
    n, held = next(((n, s) for n in range(1, 10) if (s := _hold(kind, port_of(n))) is not None), (None, None))
    if held is None:
        pytest.skip("every instance's port is in use here")
    try:
        with pytest.raises(RuntimeError, match=f"instance {n}: .*{port_of(n)} already in use"):
            start_sitl(kind, instance=n, workdir=tmp_path)
    finally:
        held.close()
    assert not any(tmp_path.iterdir())  # nothing started, nothing written
