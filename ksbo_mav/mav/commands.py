"""Commands and modes (fact sheet 1.2-1.3): COMMAND_LONG with acknowledgement and retries, arming, takeoff,
landing, mode changes confirmed by the heartbeat, message intervals, STATUSTEXT collection for error messages."""

from __future__ import annotations

import time
from collections import deque
from typing import Any

from ksbo_mav.errors import VehicleError
from ksbo_mav.mav import px4_events
from ksbo_mav.mav.link import Link
from ksbo_mav.mav.stacks import Stack
from ksbo_mav.mav.wire import mavlink

RESULTS = {0: "accepted", 1: "temporarily rejected", 2: "denied", 3: "unsupported", 4: "failed", 5: "in progress",
           6: "cancelled"}

CMD_ARM = mavlink.MAV_CMD_COMPONENT_ARM_DISARM
CMD_TAKEOFF = mavlink.MAV_CMD_NAV_TAKEOFF
CMD_SET_MODE = mavlink.MAV_CMD_DO_SET_MODE
CMD_INTERVAL = mavlink.MAV_CMD_SET_MESSAGE_INTERVAL
CMD_REQUEST_MESSAGE = mavlink.MAV_CMD_REQUEST_MESSAGE
CMD_REQUEST_CAPS = mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES


def one_line(text: str) -> str:
    """A vehicle's STATUSTEXT as one printable line (NULs dropped, line breaks and runs of spaces folded)."""
    return " ".join(text.replace("\0", "").split())


def refusal(what: str, result: int, reason: str) -> str:
    """One-line message for a refused command: what, the MAV_RESULT in words and the vehicle's reason."""
    return f"{what} {RESULTS.get(result, result)} by the vehicle" + (f": {reason}" if reason else "")


class Commander:
    """Command service of one vehicle; keeps the last STATUSTEXTs so refusals can be explained."""

    def __init__(self, link: Link) -> None:
        self.link = link
        self.stack: Stack | None = None
        self.texts: deque[tuple[int, str]] = deque(maxlen=20)
        #: STATUSTEXTs received so far: a mark that keeps counting once :attr:`texts` is full (its length does not)
        self.received = 0
        #: PX4's EVENT messages (ksbo_mav.mav.px4_events), apart from the texts: PX4 repeats its check results
        #: ("No manual control input" on a SITL) with every change, which would crowd a refusal's explanation.
        self.events: deque[tuple[int, str]] = deque(maxlen=20)
        self._chunks: dict[int, list[str]] = {}
        self.ack_wait_s = 0.0  # the least wait for an acknowledgement: sized to the link (size_for_link)
        self.extra_attempts = 0
        link.handlers.append(self._on_msg)

    def size_for_link(self, rtt_ms: float | None, loss: float) -> str:
        """Size the acknowledgement waits and attempts to the link measured before the flights: wait at least three
        round trips (a radio's queue holds a command behind seconds of telemetry), and try twice more where frames
        are lost. Returns what changed, for the console ("" when the defaults fit)."""
        self.ack_wait_s = min(10.0, 3.0 * rtt_ms / 1000.0) if rtt_ms else 0.0
        self.extra_attempts = 2 if loss > 0.02 else 0
        if self.ack_wait_s <= 1.0 and not self.extra_attempts:
            return ""
        return (f"commands: waiting up to {max(1.0, self.ack_wait_s):.1f} s for each acknowledgement, "
                f"{3 + self.extra_attempts} attempts (round trip {rtt_ms or 0:.0f} ms, {loss:.0%} of frames lost)")

    def _on_msg(self, msg: Any) -> None:
        if msg.get_type() == f"UNKNOWN_{px4_events.MSG_ID}":
            event = px4_events.decode(msg, (self.link.target_system, self.link.target_component))
            if event is not None:
                self.events.append(event[1:])
            return
        if msg.get_type() == "STATUSTEXT" and self.link.is_vehicle(msg):
            text = one_line(str(msg.text))
            tid = int(getattr(msg, "id", 0) or 0)
            if tid == 0:
                self._keep(int(msg.severity), text)
                return
            # MAVLink 2 splits long texts into 50-byte chunks with one id; the last chunk is shorter than 50.
            parts = self._chunks.setdefault(tid, [])
            parts.append(str(msg.text).replace("\0", ""))
            if len(str(msg.text).encode()) < 50 or len(parts) >= 8:
                self._keep(int(msg.severity), one_line("".join(self._chunks.pop(tid))))

    def _keep(self, severity: int, text: str) -> None:
        self.texts.append((severity, text))
        self.received += 1

    def recent_events(self, n: int = 3) -> str:
        """The last ``n`` different texts of PX4's EVENT messages, newest last ("" without any)."""
        texts = list(dict.fromkeys(t for _, t in reversed(self.events)))[:n]
        return ", ".join(f'"{t}"' for t in reversed(texts))

    def recent_text(self, since: int = 0) -> str:
        """The last three STATUSTEXTs received after the ``since``-th one (a :attr:`received` mark)."""
        first = self.received - len(self.texts)  # how many have left the bounded store
        items = list(self.texts)[max(0, since - first):]
        return "; ".join(t for _, t in items[-3:])

    def send(self, cmd: int, *params: float, confirmation: int = 0) -> None:
        """One COMMAND_LONG, not waiting for its acknowledgement (p1.. given, the rest 0)."""
        p = list(params) + [0.0] * (7 - len(params))
        link = self.link
        link.send(link.mav.command_long_encode(link.target_system, link.target_component, cmd, confirmation, *p))

    def command(self, cmd: int, *params: float, timeout: float = 1.0, retries: int = 3) -> int:
        """Send COMMAND_LONG until acknowledged; returns MAV_RESULT. :class:`VehicleError` if never acknowledged."""
        link = self.link
        timeout, retries = max(timeout, self.ack_wait_s), retries + self.extra_attempts
        for confirmation in range(retries):
            self.send(cmd, *params, confirmation=confirmation)
            ack = link.wait(lambda m: m.get_type() == "COMMAND_ACK" and m.command == cmd, timeout)
            if ack is not None:
                return int(ack.result)
        raise VehicleError(f"no COMMAND_ACK for command {cmd} after {retries} attempts of {timeout:.1f} s each")

    def attempt(self, cmd: int, *params: float, timeout: float = 1.0, retries: int = 3) -> tuple[int, str]:
        """Send a command once (with ACK retries); returns (MAV_RESULT, the vehicle's STATUSTEXT reason or "")."""
        mark = self.received
        result = self.command(cmd, *params, timeout=timeout, retries=retries)
        reason = ""
        if result != 0:
            self.link.pump(0.05)  # the STATUSTEXT explaining a refusal usually follows the ACK
            reason = self.recent_text(mark)
        return result, reason

    def require(self, what: str, cmd: int, *params: float, timeout: float = 1.0, retries: int = 3) -> None:
        """Like :meth:`command` but raises :class:`VehicleError` with the vehicle's reason unless accepted."""
        result, reason = self.attempt(cmd, *params, timeout=timeout, retries=retries)
        if result != 0:
            raise VehicleError(refusal(what, result, reason))

    # --- modes and arming ----------------------------------------------------------------------------------
    def set_mode(self, mode: str, timeout: float = 5.0) -> None:
        """Switch to the stack's ``mode`` ("guided", "hold", "land") and wait until the heartbeat shows it."""
        assert self.stack is not None
        custom = self.stack.modes[mode]
        deadline = time.monotonic() + timeout
        while True:
            self.require(f"mode {self.stack.mode_name(custom)}", CMD_SET_MODE, *self.stack.mode_params(custom))
            hb = self.link.wait(lambda m: m.get_type() == "HEARTBEAT" and m.custom_mode == custom, 1.5)
            if hb is not None:
                return
            if time.monotonic() > deadline:
                raise VehicleError(f"vehicle did not enter mode {self.stack.mode_name(custom)}")

    def takeoff(self, alt_m: float) -> None:
        self.require("takeoff", CMD_TAKEOFF, 0, 0, 0, float("nan"), float("nan"), float("nan"), alt_m)

    def set_interval(self, msg_id: int, interval_us: float) -> bool:
        """SET_MESSAGE_INTERVAL; False (not an error) when the vehicle does not stream that message."""
        return self.command(CMD_INTERVAL, msg_id, interval_us) == 0

    def request_message(self, msg_id: int, name: str, timeout: float = 1.0, attempts: int = 6) -> Any:
        """REQUEST_MESSAGE (512), every third attempt REQUEST_AUTOPILOT_CAPABILITIES instead for AUTOPILOT_VERSION
        (older firmware). Six attempts: over a link losing 20 % each way a request and its answer both get through
        64 % of the time, so three attempts left about 1 connect in 20 without an answer. The wait grows with each
        pair of attempts (1, 1, 2, 2, 3, 3 × ``timeout``): on a radio whose buffer is full of telemetry an answer
        queues for about a second before it is sent."""
        link = self.link
        for attempt in range(attempts):
            if attempt % 3 < 2 or msg_id != mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION:
                link.send(link.mav.command_long_encode(link.target_system, link.target_component,
                                                       CMD_REQUEST_MESSAGE, attempt, msg_id, 0, 0, 0, 0, 0, 0))
            else:
                link.send(link.mav.command_long_encode(link.target_system, link.target_component,
                                                       CMD_REQUEST_CAPS, 0, 1, 0, 0, 0, 0, 0, 0))
            msg = link.wait(lambda m: m.get_type() == name, timeout * (1 + attempt // 2))
            if msg is not None:
                return msg
        return None
