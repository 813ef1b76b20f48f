"""Before a PX4 campaign flies: what PX4 will do if the link dies mid-trial, said in plain words (console and
report), and a refusal when the tool does not run beside the vehicle, unless the pilot accepts the risk.

Why a refusal: PX4 has no onboard scripting, so a lost link leaves the trial's gains flying in PX4's failsafe mode
until the link returns; a companion computer beside the autopilot loses its link only when it or its wire fails.
The rule that tells the two apart is :func:`ksbo_mav.mav.link_loss.link_place`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

from ksbo_mav.errors import InputError
from ksbo_mav.mav.link_loss import LinkLossPlan, link_place, peer_host
from ksbo_mav.mav.vehicle import Vehicle

#: Seconds to listen for a telemetry radio's RADIO_STATUS (SiK radios send one a second) before deciding.
RADIO_LISTEN_S = 1.5
ACCEPT_FLAG = "--accept-link-loss-risk"
RADIO_FLAG = "--link-is-radio"


@dataclass(frozen=True)
class LinkLossChoice:
    """The pilot's say: ``accept_risk`` flies on a remote link anyway; ``declared_radio`` calls the link a radio
    whatever it looks like (a relay of a radio that sends no RADIO_STATUS)."""

    accept_risk: bool = False
    declared_radio: bool = False


def check_link_loss(v: Vehicle, choice: LinkLossChoice, log: Callable[[str], None]) -> str | None:
    """On PX4: log and return what the vehicle does if the link dies mid-trial and where the tool runs;
    InputError (one line) on a remote link without ``choice.accept_risk``. None on other stacks."""
    plan = LinkLossPlan.from_params(v.params.table) if v.stack.name == "px4" else None
    if plan is None:
        return None
    link = v.link
    deadline = time.monotonic() + RADIO_LISTEN_S
    while not link.radio_heard and time.monotonic() < deadline:
        link.pump(0.1)
    place = link_place(link.endpoint.kind, peer_host(link), link.radio_heard, choice.declared_radio)
    text = plan.describe()
    log(text)
    if place.beside_vehicle:
        where = f"The tool runs beside the vehicle: {place.why}."
    elif choice.accept_risk:
        where = f"The tool runs away from the vehicle ({place.why}); flying anyway ({ACCEPT_FLAG})."
    else:
        raise InputError(f"refused: {place.why}, so a lost link would leave the trial's gains flying in PX4's "
                         f"failsafe with nobody to restore them; run ksbo-mav on a companion computer beside the "
                         f"autopilot (docs/flight-checklist.md, \"PX4: tune from beside the vehicle\") or pass "
                         f"{ACCEPT_FLAG}")
    log(where)
    return f"{text} {where}"
