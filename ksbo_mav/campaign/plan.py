"""The plan of a campaign, printed by ``ksbo-mav tune --dry-run`` (the README's real-flight checklist): the
vehicle, the settings, the gains and their search ranges, and the flight plan from the profile and the budget (what
airspace it needs, how many flights, how long, and how many batteries)."""

from __future__ import annotations

import math
from typing import Any

from ksbo_mav.campaign.config import CampaignConfig, prior_kind, prior_size, profile_defaults
from ksbo_mav.campaign.layout import CampaignDir
from ksbo_mav.campaign.validation import ValidationPlan
from ksbo_mav.mav.approach import approach_distance, approach_seconds
from ksbo_mav.mav.gains import opt_bounds
from ksbo_mav.mav.vehicle import Vehicle
from ksbo_mav.profiles import Profile

#: Per trial on top of the figure-8: move to the start and hover there (2 s), the settle with the trial gains,
#: gain writes and the verified restore (~3 s on a telemetry radio). An estimate, not a measurement.
OVERHEAD_S = 5.0
#: Hover time of one battery pack used for the estimate (a typical 5 in - 10 in quad; change it to your own).
PACK_MIN = 12.0


def campaign_plan(v: Vehicle, cfg: CampaignConfig, d: CampaignDir, base: dict[str, float]) -> str:
    """The whole plan of a campaign with settings ``cfg`` in ``d`` on ``v``, whose baseline is ``base``
    ({autopilot parameter name: value})."""
    x0 = v.gain_map.from_params(base)
    b = opt_bounds(v.profile, x0)
    grows = v.profile.trust_region.grow
    rows = [f"  {g.name:<16} {n:<16} now {x:<10.5g} tune in [{lo:.5g}, {hi:.5g}]"
            + (f", may grow to [{g.min:.5g}, {g.max:.5g}]" if grows and (g.min < lo or g.max > hi) else "")
            for g, n, x, (lo, hi) in zip(v.profile.gains, v.gain_map.param_names, x0, b)]
    kind = prior_kind(cfg, v.profile)
    n_prior = prior_size(cfg, kind) if kind == "local" else 0  # flown prior trials
    return "\n".join([
        f"vehicle: sysid {v.identity.sysid}, {v.stack.name} {v.identity.firmware}"
        + (f", {v.gain_map.generation} parameter names" if v.gain_map.generation else ""),
        *(line for line in (v.firmware_check.line, v.firmware_check.warning) if line),
        f"profile: {v.profile.name}; method {cfg.method}, {cfg.budget} trials "
        f"(+ prior '{kind}'{prior_note(kind, prior_size(cfg, kind))}), seed {cfg.seed}" + options_note(cfg, v.profile),
        "gains (profile name, vehicle name, current value, the first search box and how far it may grow):", *rows,
        flight_plan(v.profile, n_prior, cfg.budget, cfg.confirm, cfg.settle_s, cfg.baseline_every),
        *([v.wind_plan] if getattr(v, "wind_plan", None) else []),  # tune --wind: ksbo_mav.campaign.wind_preflight
        ValidationPlan.describe(v.profile, cfg.validation),
        *([f"early stop: the search may end after {cfg.min_trials} trials, when the next flight's expected gain is "
           "below the re-flight noise (--no-early-stop flies the budget)"] if cfg.early_stop else []),
        f"at the end: {'write the best gains (accept)' if cfg.accept else 'restore the baseline'}, "
        f"then {cfg.end}",
        f"logs: {d.trials}, snapshot {d.snapshot_stem.parent}"])


def options_note(cfg: CampaignConfig, profile: Any) -> str:
    """The optimiser options that differ from the method's defaults (the profile's, then the user's)."""
    implied = profile_defaults(cfg.method, profile)
    parts = [f"{k}={v} (profile: the backup covers its trials)" for k, v in implied.items() if k not in cfg.options]
    parts += [f"{k}={v}" for k, v in cfg.options.items()]
    return f"; options {', '.join(parts)}" if parts else ""


def prior_note(kind: str, n: int) -> str:
    """What the prior costs: flown trials, simulator episodes computed before takeoff, or nothing."""
    return {"local": f": {n} flown trials", "sim": f": {n} simulator episodes in process, nothing flown"}.get(kind, "")


def planned_flights(n_prior: int, budget: int, confirm: int, baseline_every: int) -> tuple[int, int]:
    """(every flight of a campaign, of which baseline re-flights) at most: the baseline, the flown prior, the
    optimiser's trials, a re-flight of the baseline after every ``baseline_every`` of those (the cadence stretches
    while the re-flights stay quiet, so this is the most), the confirmation."""
    trials = n_prior + max(0, budget - 1)
    reflights = trials // baseline_every if baseline_every else 0
    return 1 + trials + reflights + confirm, reflights


def flight_plan(profile: Profile, n_prior: int, budget: int, confirm: int, settle_s: float,
                baseline_every: int = 0) -> str:
    """Multi-line plan: airspace, abort box, flights x duration, total and batteries."""
    m, s = profile.mission_spec, profile.safety
    if m.type == "figure8-ne":
        east = m.scale_east_m if m.scale_east_m is not None else m.scale_m
        area = (f"figure-8 {2 * m.scale_m:g} m north-south x {2 * east:g} m east-west at {m.center_up_m:g} m height, "
                "centred on the local origin (home / EKF origin)")
    else:
        area = (f"figure-8 {2 * m.scale_m:g} m along x, {m.scale_m:g} m tall around {m.center_up_m:g} m height "
                "(planar x-z)")
        if m.start_speed_mps:
            reach = approach_distance(m.start_speed_mps, 1.0 / m.rate_hz)
            area += f"; approaches to the moving starts fly within {reach:.2f} m of the figure-8 start"
    east_box = f"|east| <= {s.y_max_m:g} m, " if math.isfinite(s.y_max_m) else ""
    stop = "" if s.brake_accel_mps2 is None else f" (at the stopping point, braking {s.brake_accel_mps2:g} m/s^2)"
    approach = approach_seconds(m.start_speed_mps)  # a moving start's approach, at most
    trial_s = m.laps * m.period_s + 2 * settle_s + approach + OVERHEAD_S  # settle before, monitored hold after
    flights, reflights = planned_flights(n_prior, budget, confirm, baseline_every)
    total_min = flights * trial_s / 60.0
    packs = math.ceil(total_min / (0.8 * PACK_MIN))
    return "\n".join([
        f"airspace: {area}",
        f"abort box: |north| <= {s.x_max_m:g} m, {east_box}height {s.z_min_m:g}-{s.z_max_m:g} m{stop}, tilt "
        f"<= {s.tilt_max_deg:g} deg, tracking error <= {s.tracking_error_max_m:g} m, heartbeat gap <= "
        f"{s.heartbeat_timeout_s:g} s",
        f"flights: {flights} at most (1 baseline + {n_prior} prior + {max(0, budget - 1)} optimiser + up to "
        f"{reflights} baseline re-flight{'' if reflights == 1 else 's'} + {confirm} confirmation) x "
        f"~{trial_s:.0f} s ({m.laps} x {m.period_s:g} s figure-8 + 2 x settle"
        + (f" + {approach:.1f} s approach to a moving start (up to {m.start_speed_mps:g} m/s)" if approach else "")
        + f" + ~{OVERHEAD_S:g} s) "
        f"= ~{total_min:.0f} min in the air, plus takeoff and landing",
        f"batteries: ~{packs} pack(s) of {PACK_MIN:g} min hover used to 80 % (an estimate; swap with Ctrl-C, land, "
        "then --resume)",
        "the tool arms, takes off and lands by itself; a pilot stays ready to take over (any mode change stops it)",
    ])
