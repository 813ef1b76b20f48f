"""`ksbo-mav evaluate`: fly gains on the in-process simulator and print P(a)."""

from __future__ import annotations

import argparse

import numpy as np

from ksbo_mav.cli.common import parse_gains, planar_profile, positive_int, to_json

HELP = "fly PID gains on the built-in planar simulator (figure-8) and print their score P(a)"


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "evaluate", help=HELP, description=HELP + ". P(a) = J^R_scaled - (1 - lambda (L/L_expected)^2); "
        "P < 0 means unsafe (crash or poor tracking). Each episode starts at the figure-8 origin with a random "
        "initial velocity (|v| < 1 m/s); --fixed uses the 8 fixed initial conditions of the re-flown score.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--gains", default="default",
                   help="'default' (known-safe start gains), 'scg' (Safe Control Gym's gains) or 9 comma-separated "
                        "values Px,Ix,Dx,Pz,Iz,Dz,Ptheta,Itheta,Dtheta")
    p.add_argument("--profile", default="sim-planar", help="planar vehicle profile name or TOML path")
    p.add_argument("--episodes", type=positive_int, default=1, help="episodes to fly (scores are averaged)")
    p.add_argument("--fixed", action="store_true", help="fly the 8 fixed initial conditions instead of random ones")
    p.add_argument("--seed", type=int, default=0, help="seed of the random initial velocities")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    p.add_argument("--plot", metavar="FILE.png", help="draw reference vs flown trajectory and x/z errors")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ksbo_mav.simulated.planar_objective import SimObjective
    from ksbo_task.starts import fixed_initial_states, random_initial_states

    profile = planar_profile(args.profile, "evaluate")
    gains = profile.check_gains(parse_gains(args.gains, profile), within_box=False)
    obj = SimObjective(profile, seed=args.seed)
    rng = np.random.default_rng(args.seed)
    init = (fixed_initial_states(figure8=obj.episode.figure8) if args.fixed
            else random_initial_states(args.episodes, rng, obj.episode.figure8))
    flights = [obj.fly(gains, init=row) for row in init]
    scores = [f.score for f in flights]
    P = np.array([s["P"] for s in scores])
    JQ = np.array([np.nan if s["JQ"] is None else s["JQ"] for s in scores])
    complete = ~np.isnan(JQ)
    result = {
        "profile": profile.name,
        "gains": dict(zip(profile.names, gains.tolist())),
        "episodes": len(flights),
        "P": float(P.mean()),
        "JQ": float(JQ[complete].mean()) if complete.any() else None,
        "JR": float(-JQ[complete].mean()) if complete.any() else None,
        "L": float(np.mean([s["L"] for s in scores])),
        "L_expected": obj.score_config.L_expected,
        "safe": bool(np.all(P >= 0.0)),
        "n_unsafe": int(np.sum(P < 0.0)),
        "per_episode": [{**s, "outcome": f.outcome, "init_velocity": f.meta["init"][1::2][:2]}
                        for s, f in zip(scores, flights)],
    }
    if args.plot:
        from ksbo_mav.plotting import plot_trajectories

        trajs, labels = [flights[0].trajectory], [f"gains (P = {P[0]:.3f})"]
        if not np.allclose(gains, profile.default):
            base = obj.fly(profile.default, init=init[0])
            trajs.insert(0, base.trajectory)
            labels.insert(0, f"default gains (P = {base.P:.3f})")
        path = plot_trajectories(trajs, labels, args.plot, title=f"Figure-8 tracking, {profile.name}")
        result["plot"] = str(path)
    if args.json:
        print(to_json(result))
        return 0
    print(f"profile {profile.name}: " + ", ".join(f"{lab}={v:g}" for lab, v in zip(profile.labels, gains)))
    print(f"{'episode':>7} {'P':>9} {'J^Q':>9} {'J^R':>9} {'L':>5} {'L_exp':>6}  outcome")
    for i, (s, f) in enumerate(zip(scores, flights)):
        jq = "-" if s["JQ"] is None else f"{s['JQ']:.4f}"
        jr = "-" if s["JR"] is None else f"{s['JR']:.4f}"
        print(f"{i:>7} {s['P']:>9.4f} {jq:>9} {jr:>9} {s['L']:>5} {s['L_expected']:>6}  "
              f"{'safe' if s['safe'] else 'UNSAFE'}, {f.outcome}")
    if len(flights) > 1:
        jq = "-" if result["JQ"] is None else f"{result['JQ']:.4f}"
        print(f"{'mean':>7} {result['P']:>9.4f} {jq:>9}  ({result['n_unsafe']} unsafe of {len(flights)})")
    if args.plot:
        print(f"plot written to {result['plot']}")
    return 0
