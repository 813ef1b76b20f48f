"""Which of a SITL instance's ports something already holds (a second autopilot on them would die at once, and
its start would take the first one's heartbeat for its own). Standard library only."""

from __future__ import annotations

import socket


def ports_taken(kind: str, n: int) -> list[str]:
    """The ports instance ``n`` of ``kind`` binds (and its client listens on) that something holds right now.

    TCP ports are probed with SO_REUSEADDR, as the autopilot binds them: a port whose last connections linger in
    TIME_WAIT is free, one with a listener is not. UDP ports without it: any holder counts (pymavlink's ``udpin``
    sets SO_REUSEADDR and would share the port unseen)."""
    tcp = [5760 + 10 * n, 5762 + 10 * n, 5763 + 10 * n] if kind == "ardupilot" else []
    udp = [5501 + 10 * n] if kind == "ardupilot" else [14540 + n, 14580 + n, 18570 + n]
    taken = []
    for family, ports in ((socket.SOCK_STREAM, tcp), (socket.SOCK_DGRAM, udp)):
        for port in ports:
            with socket.socket(socket.AF_INET, family) as s:
                if family == socket.SOCK_STREAM:
                    s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                try:
                    s.bind(("127.0.0.1", port))
                except OSError:
                    taken.append(f"{'TCP' if family == socket.SOCK_STREAM else 'UDP'} {port}")
    return taken
