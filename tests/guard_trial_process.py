"""A tuner stand-in that holds the link during a guarded trial, in its own process so a test can cut the link by
killing it: ``python tests/guard_trial_process.py DEVICE PROFILE CONFIG_JSON`` (DEVICE: ``tcp:HOST:PORT`` or
``udpout:HOST:PORT``).

It connects as the tuner does, installs the onboard guard with the baseline gains, takes off in GUIDED, writes the
trial gains, arms the guard and prints ``ARMED`` (then a JSON line with the baseline and trial values), then keeps
pumping the link (heartbeats) until killed. ``CONFIG_JSON``: ``{"trial": {name: value}, "limits": {profile safety
key: value}, "fly_to": [n, e, d] or null}``."""

from __future__ import annotations

import json
import sys

import numpy as np

from ksbo_mav.mav.guard_script import config_for, new_config_id
from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.monitor import limits_from_profile
from ksbo_mav.mav.onboard_guard import OnboardGuard
from ksbo_mav.mav.vehicle import Vehicle


def main(device: str, profile: str, spec: dict) -> None:
    kind, host, port = device.split(":")
    v = Vehicle.connect(Endpoint(kind, host, int(port)), profile, log=lambda s: print(s, flush=True))
    baseline = {name: v.params.read(name) for name in v.gain_map.param_names}
    guard = OnboardGuard(v.link, v.params, v.cmd, log=lambda s: print(s, flush=True))
    limits = limits_from_profile(v.profile, spec.get("limits"))
    guard.install(config_for(limits, v.profile.safety.heartbeat_timeout_s, baseline, new_config_id()))
    v.setup_streams()
    v.ensure_airborne(log=lambda s: print(s, flush=True))
    for name, value in spec["trial"].items():
        v.params.set_verified(name, value)
    guard.arm_trial()
    print("ARMED", flush=True)
    print(json.dumps({"baseline": baseline, "trial": spec["trial"]}), flush=True)
    if spec.get("fly_to") is not None:
        v.guided.hold_at(np.asarray(spec["fly_to"], float))
    while True:
        v.link.pump(0.1)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], json.loads(sys.argv[3]))
