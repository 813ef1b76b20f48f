"""`ksbo-mav prior`: draw a Latin-hypercube prior and fly it on the in-process simulator; write a CSV."""

from __future__ import annotations

import argparse

import numpy as np

from ksbo_mav.cli.common import planar_profile, positive_float, positive_int, to_json
from ksbo_mav.errors import InputError

HELP = "draw a Latin-hypercube prior of gains, fly each on the simulator, and write gains + P to a CSV"


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "prior", help=HELP, description=HELP + ". 'box' samples the whole search box (the paper's setting; most "
        "points crash); 'local' samples a trust region of +-radius (unit-cube units) around the profile's safe "
        "default gains, clipped to the box. P < 0 means unsafe.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--n", type=positive_int, default=36, help="number of prior points")
    p.add_argument("--design", choices=("box", "local"), default="box", help="where to sample")
    p.add_argument("--radius", type=positive_float, default=0.1,
                   help="half-width of the local trust region in unit-cube units")
    p.add_argument("--seed", type=int, default=0, help="seed of the design and of the initial velocities")
    p.add_argument("--episodes", type=positive_int, default=1,
                   help="episodes per point (random initial velocities; P is their mean)")
    p.add_argument("--profile", default="sim-planar", help="planar vehicle profile name or TOML path")
    p.add_argument("--out", required=True, metavar="FILE.csv", help="output CSV (gain columns and P)")
    p.add_argument("--json", action="store_true", help="print a JSON summary instead of text")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ksbo_mav.simulated.planar_objective import SimObjective
    from ksbo_mav.select.design import lhs_design
    from ksbo_mav.select.prior_csv import write_prior_csv

    profile = planar_profile(args.profile, "prior")
    if args.design == "local" and not np.all(np.isfinite(profile.to_unit(profile.default))):
        raise InputError(f"profile {profile.name!r} has no usable default gains for a local design")
    U = lhs_design(args.n, profile.dim, design=args.design, center=profile.to_unit(profile.default),
                   radius=args.radius, seed=args.seed)
    X = profile.from_unit(U)
    obj = SimObjective(profile, seed=args.seed)
    P = np.mean([obj.batch(X) for _ in range(args.episodes)], axis=0)
    path = write_prior_csv(args.out, profile.names, X, P)
    summary = {
        "out": str(path), "profile": profile.name, "n": int(args.n), "design": args.design,
        "radius": args.radius if args.design == "local" else None, "seed": args.seed, "episodes": args.episodes,
        "n_unsafe": int(np.sum(P < 0)), "P_best": float(P.max()), "P_median": float(np.median(P)),
        "best_gains": dict(zip(profile.names, X[int(np.argmax(P))].tolist())),
    }
    if args.json:
        print(to_json(summary))
        return 0
    where = "whole box" if args.design == "box" else f"+-{args.radius:g} around the default gains"
    print(f"{args.n} LHS points ({where}), {args.episodes} episode(s) each, profile {profile.name}")
    print(f"unsafe (P < 0): {summary['n_unsafe']} of {args.n}; P median {summary['P_median']:.4f}, "
          f"best {summary['P_best']:.4f}")
    print(f"written to {path}")
    return 0
