"""What the vehicle does on its own when this link dies mid-trial, and whether the tool runs beside the vehicle.

A trial's gains are parameters on the vehicle; only the tool restores the baseline, and only over the link. PX4
has no onboard scripting to undo them: when the link dies, PX4's own failsafes fly the vehicle with the trial's
gains until the link returns. Two of them matter here (meanings as PX4 v1.15 documents its parameters):

* offboard loss: no setpoint for ``COM_OF_LOSS_T`` s while in OFFBOARD (a trial) -> the mode ``COM_OBL_RC_ACT``
  names. Position, Altitude and Manual need an RC transmitter; without one PX4's mode fallback ends in Return.
* data-link loss: no ground-station heartbeat for ``COM_DL_LOSS_T`` s -> ``NAV_DLL_ACT`` (0: no action). It also
  covers the vehicle parked in Hold between trials, and stays quiet while another ground station's heartbeat still
  arrives.

Where the tool runs (:func:`link_place`): *beside the vehicle* (a companion computer) when the link is a wire (a
serial device) or TCP/UDP to an address of this machine, *remote* otherwise, and always remote when a telemetry
radio reports itself on the link (RADIO_STATUS, as SiK/RFD radios send it, also through a relay such as MAVProxy)
or the user says the link is a radio. On a link beside the vehicle a loss of link means the companion computer or
its wire failed, not the air.
"""

from __future__ import annotations

import ipaddress
import socket
from dataclasses import dataclass
from typing import Any

from ksbo_mav.mav.px4_generation import offboard_loss_mode_2, stick_override_words

#: COM_OBL_RC_ACT (v1.15; PX4 main calls 2 "Stabilized"): the mode after offboard loss.
OFFBOARD_LOSS_ACTION = {0: "Position mode", 1: "Altitude mode", 2: "Manual mode", 3: "Return mode",
                        4: "Land mode", 5: "Hold mode", 6: "flight termination (motors off)", 7: "disarm"}
#: The offboard-loss modes PX4 flies only with an RC transmitter (the pilot's sticks).
NEEDS_RC = (0, 1, 2)
#: NAV_DLL_ACT (v1.15): the action after data-link (ground station) loss; 0 disables it.
DATA_LINK_LOSS_ACTION = {0: "no action", 1: "Hold mode", 2: "Return mode", 3: "Land mode",
                         5: "flight termination (motors off)", 6: "disarm"}
PARAMS = ("COM_OF_LOSS_T", "COM_OBL_RC_ACT", "NAV_DLL_ACT", "COM_DL_LOSS_T")


@dataclass(frozen=True)
class LinkLossPlan:
    """PX4's link-loss failsafes as set on the vehicle."""

    offboard_loss_s: float
    offboard_action: int
    data_link_action: int
    data_link_loss_s: float
    #: How the pilot's sticks end OFFBOARD on this PX4 generation (:mod:`ksbo_mav.mav.px4_generation`).
    stick_override: str = ""
    #: COM_OBL_RC_ACT 2's name on this generation ("Manual mode" up to 1.17, "Stabilized mode" after).
    mode_2: str = OFFBOARD_LOSS_ACTION[2]

    @classmethod
    def from_params(cls, table: dict[str, Any]) -> "LinkLossPlan | None":
        """From the downloaded parameter table ({name: Param}); None when one of the four is missing (not PX4)."""
        if any(n not in table for n in PARAMS):
            return None
        value = {n: float(table[n].value) for n in PARAMS}
        sticks = {n: float(table[n].value) for n in ("MAN_OVERRIDE_SPD", "COM_RC_OVERRIDE", "COM_RC_STICK_OV")
                  if n in table}
        return cls(value["COM_OF_LOSS_T"], int(value["COM_OBL_RC_ACT"]), int(value["NAV_DLL_ACT"]),
                   value["COM_DL_LOSS_T"], stick_override_words(sticks), offboard_loss_mode_2(table))

    def offboard_words(self) -> str:
        names = {**OFFBOARD_LOSS_ACTION, 2: self.mode_2}
        mode = names.get(self.offboard_action, f"action {self.offboard_action} (unknown)")
        said = f"{mode} (COM_OBL_RC_ACT {self.offboard_action})"
        return said + (" with an RC transmitter connected, else Return mode (PX4's fallback without one)"
                       if self.offboard_action in NEEDS_RC else "")

    def data_link_words(self) -> str:
        if self.data_link_action == 0:
            return "PX4's data-link-loss failsafe is off (NAV_DLL_ACT 0): parked in Hold between trials, it stays there"
        action = DATA_LINK_LOSS_ACTION.get(self.data_link_action, f"action {self.data_link_action} (unknown)")
        return (f"after {self.data_link_loss_s:g} s without a ground station's heartbeat (COM_DL_LOSS_T) it switches "
                f"to {action} (NAV_DLL_ACT {self.data_link_action}), also between trials")

    def describe(self) -> str:
        """The plain-words account shown before arming and kept in the campaign's report."""
        return (f"If the link dies mid-trial, PX4 leaves OFFBOARD {self.offboard_loss_s:g} s after the last setpoint "
                f"(COM_OF_LOSS_T) for {self.offboard_words()}; {self.data_link_words()}. The trial's gains stay on "
                "the vehicle until the link returns and the tool restores the baseline: PX4 has nothing on board "
                "to restore them." + (f" A pilot's sticks: {self.stick_override}." if self.stick_override else ""))


@dataclass(frozen=True)
class LinkPlace:
    beside_vehicle: bool
    why: str


def _own_address(host: str) -> str | None:
    """``host``'s address when it is this machine's (loopback, or an address of one of its interfaces), else None.
    An address is this machine's exactly when a socket can bind to it."""
    try:
        addr = socket.getaddrinfo(host, None, type=socket.SOCK_DGRAM)[0][4][0]
    except (OSError, IndexError):
        return None
    if ipaddress.ip_address(addr.split("%")[0]).is_loopback:
        return addr
    family = socket.AF_INET6 if ":" in addr else socket.AF_INET
    with socket.socket(family, socket.SOCK_DGRAM) as s:
        try:
            s.bind((addr, 0))
        except OSError:
            return None
    return addr


def link_place(kind: str, peer_host: str | None, radio_heard: bool, declared_radio: bool) -> LinkPlace:
    """Whether the tool runs beside the vehicle on this link (see the module's docstring for the rule).
    ``kind``: the endpoint's kind; ``peer_host``: the vehicle side's address (None: not known yet)."""
    if declared_radio:
        return LinkPlace(False, "the link is declared a radio (--link-is-radio)")
    if radio_heard:
        return LinkPlace(False, "a telemetry radio reports itself on the link (RADIO_STATUS)")
    if kind == "serial":
        return LinkPlace(True, "a serial wire with no telemetry radio on it")
    if peer_host and _own_address(peer_host):
        return LinkPlace(True, f"the vehicle's side of the link ({peer_host}) is this machine")
    return LinkPlace(False, f"the vehicle's side of the link ({peer_host or 'unknown'}) is another machine")


def peer_host(link: Any) -> str | None:
    """The vehicle side's address on ``link`` (a :class:`~ksbo_mav.mav.link.Link`): on a UDP port we listen on, the
    senders heard (one of another machine first), else the endpoint's host; None for a serial device (or a UDP port
    that heard nobody yet)."""
    ep = link.endpoint
    if ep.kind == "serial":
        return None
    if ep.kind == "udp":
        senders = sorted(host for host, _port in getattr(link.conn, "clients", ()))
        return next((h for h in senders if _own_address(h) is None), senders[0] if senders else None)
    return ep.host
