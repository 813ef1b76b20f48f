"""`ksbo-mav select`: Nyström kernel selection (C_ree table, chosen orders) and dimension selection on a prior CSV."""

from __future__ import annotations

import argparse


from ksbo_mav.cli.common import positive_float, positive_int, to_json

HELP = "rank additive-kernel orders by C_ree (Algorithm 1, repeated) and pick the dimensions of each chosen order"


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "select", help=HELP, description=HELP + ". Gains are scaled to the unit cube with the profile's box and P "
        "is standardised before C_ree; lower C_ree is better. mu is Algorithm 1's mu (= l x the kernel-ridge "
        "regulariser).", formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("csv", metavar="prior.csv", help="prior data: the profile's gain columns and P")
    p.add_argument("--trials", type=positive_int, default=1000, help="repetitions T of Algorithm 1")
    p.add_argument("--top", type=positive_int, default=3, help="number of orders kept")
    p.add_argument("--columns", type=positive_int, default=None, help="sampled columns c (default round(0.8 l))")
    p.add_argument("--rank", type=positive_int, default=None, help="rank k kept from W (default c)")
    p.add_argument("--mu", type=positive_float, default=0.1, help="Algorithm 1's mu")
    p.add_argument("--lengthscale", type=positive_float, default=0.2,
                   help="base-kernel lengthscale in unit-cube units")
    p.add_argument("--max-order", type=positive_int, default=None, help="highest order ranked (default D)")
    p.add_argument("--dims-method", choices=("forest", "permutation"), default="forest",
                   help="dimension importance: random-forest impurity (paper) or held-out permutation")
    p.add_argument("--threshold", type=positive_float, default=0.5,
                   help="keep dimensions whose importance share is >= threshold / D")
    p.add_argument("--seed", type=int, default=0, help="seed of the column sampling and the forest")
    p.add_argument("--profile", default="sim-planar", help="vehicle profile name or TOML path (gain names, box)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    p.add_argument("--plot", metavar="FILE.png", help="draw the C_ree bar chart")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ksbo_mav.errors import InputError
    from ksbo_mav.profiles import load_profile
    from ksbo_mav.select.dims import select_dimensions_for_orders
    from ksbo_mav.select.orders import select_orders
    from ksbo_mav.select.prior_csv import read_prior_csv

    profile = load_profile(args.profile)
    X_phys, P = read_prior_csv(args.csv, profile.names)
    profile.check_gains(X_phys, within_box=False)
    X = profile.to_unit(X_phys)
    l, D = X.shape
    max_order = D if args.max_order is None else args.max_order
    if max_order > D:
        raise InputError(f"--max-order must be at most {D}")
    if args.columns is not None and args.columns > l:
        raise InputError(f"--columns must be at most the number of prior points ({l}), got {args.columns}")
    if args.top > max_order:
        raise InputError(f"--top must be at most the number of orders ({max_order}), got {args.top}")
    sel = select_orders(X, P, orders=range(1, max_order + 1), trials=args.trials, top=args.top,
                        columns=args.columns, rank=args.rank, mu=args.mu, seed=args.seed,
                        lengthscales=args.lengthscale)
    dims = select_dimensions_for_orders(X, P, sel.orders, method=args.dims_method, threshold=args.threshold,
                                        seed=args.seed)
    names = profile.names
    result = {
        **sel.to_dict(),
        "dims": {str(r): [names[i] for i in d.dims] for r, d in dims.items()},
        "importances": dict(zip(names, next(iter(dims.values())).importances.tolist())),
        "dims_method": args.dims_method,
        "l": l,
        "y_mean": sel.y_mean,
        "y_std": sel.y_std,
    }
    if args.plot:
        from ksbo_mav.select.cree_plot import plot_cree

        result["plot"] = str(plot_cree(sel, args.plot, title=f"C_ree on {args.csv}"))
    if args.json:
        print(to_json(result))
        return 0
    print(f"C_ree over {sel.trials} trials: l={l}, c={sel.columns}, k={sel.rank}, mu={sel.mu:g}, "
          f"lengthscale={args.lengthscale:g}; P standardised (mean {sel.y_mean:.4g}, std {sel.y_std:.4g})")
    print(f"{'order':>5}  {'mean C_ree':>11}  {'std':>9}  {'top-' + str(sel.top):>6}  {'exact (c=l)':>11}  rank")
    for r in sorted(sel.mean):
        mark = "  *" if r in sel.orders else ""
        print(f"{r:>5}  {sel.mean[r]:>11.6f}  {sel.std[r]:>9.6f}  {100 * sel.top_frequency[r]:>5.1f}%  "
              f"{sel.exact[r]:>11.6f}  {sel.ranking.index(r) + 1:>4}{mark}")
    print(f"chosen orders (best first): {', '.join(map(str, sel.orders))}")
    imp = result["importances"]
    print(f"dimension importance ({args.dims_method}): "
          + ", ".join(f"{n} {imp[n]:.3f}" for n in sorted(imp, key=lambda n: -imp[n])))
    for r in sel.orders:
        print(f"  order {r}: keep {', '.join(result['dims'][str(r)])}")
    if args.plot:
        print(f"plot written to {result['plot']}")
    return 0
