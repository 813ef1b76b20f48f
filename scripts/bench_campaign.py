#!/usr/bin/env python
"""Safe BO benchmark campaign on the planar simulator (issue 5): methods × seeds × settings.

Settings:
  paper    36-point uniform LHS prior over the whole box (flown in the simulator; its unsafe points are reported
           separately), then 150 evaluations (LineBO 200) starting with the default gains a0.
  vehicle  a0 plus a small local LHS prior around a0 (``--local-n`` points within ``--local-radius`` of a0 in the
           unit cube), all flown and *counted in the 100-evaluation budget*.

Every run writes one JSON file (resumable: existing files are skipped) with the evaluations, the re-flown E[P]
and J^Q of the recommendation over the 8 fixed initial conditions, unsafe counts and optimiser seconds. Runs go
to 2 worker processes with BLAS pinned to one thread. ``--report`` aggregates into BENCHMARKS.md (section
"## Safe BO campaign (issue 5)") and draws the figures.

    python scripts/bench_campaign.py --settings vehicle paper --seeds 10          # run (resumable)
    python scripts/bench_campaign.py --report                                      # tables + figures only
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench_common import machine, write_section  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "campaign"  # overridden by --out
FIG = ROOT / "docs" / "figures"
SECTION = "## Safe BO campaign (issue 5)"
ALL_METHODS = ("ksbo", "standard", "safeopt", "linebo", "ucb", "ei", "random")
#: Ablations of ksbo: campaign name -> (method, extra options). Not run by default (``--methods`` to add them).
VARIANTS: dict[str, tuple[str, dict]] = {
    "ksbo-234": ("ksbo", {"orders": (2, 3, 4)}),  # the paper's selected orders, no selection
    "ksbo-nosafetygp": ("ksbo", {"safety_kernel": "same"}),  # additive GP alone certifies safety
    # Issue 4's dimension selection inside ksbo: random-forest-kept dims in the interaction orders, the dropped
    # ones either held at their start value ("fixed") or kept only as first-order terms ("order1").
    "ksbo-dims-fixed": ("ksbo", {"dims": "forest", "dropped": "fixed"}),
    "ksbo-dims-order1": ("ksbo", {"dims": "forest", "dropped": "order1"}),
    # The library defaults before the last tuning round (safety GP lengthscale 0.07, no final exploitation,
    # candidates around any certified observation plus global Sobol points), and a faster-expanding version of
    # it (safety lengthscale 0.14): the speed/safety trade-off of the vehicle-safe goal.
    "ksbo-prev": ("ksbo", {"safety_lengthscale": 0.07, "exploit_last": 0, "explore_from": "all"}),
    "ksbo-fast": ("ksbo", {"safety_lengthscale": 0.14, "exploit_last": 0, "explore_from": "all"}),
}
ALL_NAMES = ALL_METHODS + tuple(VARIANTS)

#: Method options used in the campaign (documented in BENCHMARKS.md); shared by all safe methods unless noted.
#: P lies in [-1, 1] (so prior std 1 on the margin P - 0) and P <= 1 is known (y_max). Everything else is the
#: library default (opt.options.Options): beta 4 / beta_ucb 2, additive lengthscale 0.1, SE safety GP 0.07;
#: ksbo's own defaults (opt.options.METHOD_DEFAULTS): orders selected among 1..4 (max_order), beta 5.
SAFE_COMMON = {"signal_std": 1.0, "y_max": 1.0}
METHOD_OPTIONS: dict[str, dict] = {
    "ksbo": {**SAFE_COMMON},
    "standard": {**SAFE_COMMON},
    "safeopt": {**SAFE_COMMON},
    "linebo": {**SAFE_COMMON},
    "ucb": {"unconstrained_refit": 10},
    "ei": {"unconstrained_refit": 10},
    "random": {},
}
#: ksbo per setting: the vehicle setting selects again after 25 BO iterations (its prior is a tiny local cloud).
KSBO_SETTING = {"vehicle": {"select_at": 25}, "paper": {}}


def task_seed(seed: int) -> int:
    """Objective seed of campaign seed ``seed`` (the same for every method: same noise stream, same prior)."""
    return 10_000 + seed


def make_prior(setting: str, seed: int, prof, obj, args) -> tuple[np.ndarray, np.ndarray]:
    """Prior design of ``setting`` (physical gains (m, 9), flown values (m,)), seed-shared across methods."""
    from scipy.stats import qmc

    rng = np.random.default_rng(task_seed(seed) + 1)
    if setting == "paper":
        U = qmc.LatinHypercube(d=9, seed=rng).random(36)
    else:
        if args.local_n == 0:
            return np.zeros((0, 9)), np.zeros(0)
        u0 = prof.to_unit(prof.default)
        U = np.clip(u0 + (2 * qmc.LatinHypercube(d=9, seed=rng).random(args.local_n) - 1) * args.local_radius, 0, 1)
    X = prof.from_unit(U)
    return X, obj.batch(X)


def refly(obj, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Re-fly gains X (n, 9) over the 8 fixed initial conditions: E[P], mean J^Q, crashed re-flights (each (n,))."""
    from ksbo_sim.episode import fixed_initial_states

    inits = fixed_initial_states(config=obj.episode)
    n, m = X.shape[0], inits.shape[0]
    s = obj.scores(np.repeat(X, m, axis=0), np.tile(inits, (n, 1)))
    P = s.P.reshape(n, m)
    done = np.asarray(s.complete, bool).reshape(n, m)
    jq = np.where(done, s.JQ.reshape(n, m), 0.0).sum(1) / np.maximum(done.sum(1), 1)
    jq = np.where(done.any(1), jq, np.nan)
    return P.mean(1), jq, (~done).sum(1)


def run_one(setting: str, method: str, seed: int, args_d: dict) -> dict:
    """One campaign run (in a worker process). Returns the JSON record."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)
    import ksbo_mav
    from ksbo_mav.jsonio import jsonable
    from ksbo_mav.objective import SimObjective
    from ksbo_mav.profiles import load_profile

    args = argparse.Namespace(**args_d)
    prof = load_profile("sim-planar")
    obj = SimObjective(prof, seed=task_seed(seed))
    pX, py = make_prior(setting, seed, prof, obj, args)
    if setting == "paper":
        budget = 200 if method == "linebo" else 150
        counted = 0
    else:
        budget = 100 - len(py)
        counted = len(py)
    name = method
    method, extra = VARIANTS.get(name, (name, {}))
    opts = dict(METHOD_OPTIONS[method])
    if method == "ksbo":
        opts.update(KSBO_SETTING[setting])
    opts.update(extra)
    if "orders" in opts:
        opts.pop("select_at", None)
    t0 = time.perf_counter()
    res = ksbo_mav.optimize(obj, prof.default, prof.bounds, budget=budget, method=method,
                            prior=(pX, py) if len(py) else None, seed=seed, **opts)
    wall = time.perf_counter() - t0
    E, JQ, crashed = refly(obj, np.vstack([res.x, prof.default]))
    # J^Q is only defined for complete flights (crashed ones are scored by L); NaN if every re-flight crashed.
    # All flights in order: the counted prior (vehicle setting) then the optimiser's evaluations.
    flights = np.concatenate([py, res.y]) if counted else res.y
    return {
        "setting": setting, "method": name, "seed": seed, "budget": budget, "n_prior": int(len(py)),
        "prior_counted": bool(counted), "prior_unsafe": int(np.sum(py < 0)), "prior_y": py.tolist(),
        "y": res.y.tolist(), "flights": flights.tolist(),
        "n_unsafe": int(res.n_unsafe), "unsafe_flights": int(np.sum(flights < 0)),
        "best_observed": float(np.max(flights)), "x": res.x.tolist(), "fun": float(res.fun),
        "E": float(E[0]), "JQ": float(JQ[0]), "crashed_reflights": int(crashed[0]),
        "E_a0": float(E[1]), "JQ_a0": float(JQ[1]),
        "JR_improvement": float((JQ[1] - JQ[0]) / JQ[1]),
        "orders": list(res.orders) if res.orders else None, "dims": list(res.dims) if res.dims else None,
        "selection": jsonable(res.info.get("selection")),
        "reselection": jsonable(res.info.get("reselection")),
        "seconds": res.seconds.tolist(), "s_per_iter": float(np.mean(res.seconds[1:])) if res.nfev > 1 else 0.0,
        "fallbacks": int(res.fallbacks), "wall": wall, "options": opts,
    }


def path_of(setting: str, method: str, seed: int) -> Path:
    return OUT / setting / f"{method}_seed{seed:02d}.json"


def run_campaign(args) -> None:
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    seeds = range(args.seed_offset, args.seed_offset + args.seeds)
    tasks = [(s, m, k) for s in args.settings for k in seeds for m in args.methods if not path_of(s, m, k).exists()]
    log = open(OUT / "campaign.log", "a")
    print(f"{len(tasks)} runs to do ({args.workers} workers)", file=log, flush=True)
    args_d = {"local_n": args.local_n, "local_radius": args.local_radius}
    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn()) as bar:
        tid = bar.add_task("campaign", total=len(tasks))
        with ProcessPoolExecutor(args.workers) as ex:
            futs = {ex.submit(run_one, s, m, k, args_d): (s, m, k) for s, m, k in tasks}
            for f in as_completed(futs):
                s, m, k = futs[f]
                try:
                    rec = f.result()
                except Exception as exc:  # keep the campaign going; the run is retried next time
                    print(f"FAILED {s} {m} {k}: {exc!r}", file=log, flush=True)
                    bar.advance(tid)
                    continue
                p = path_of(s, m, k)
                p.parent.mkdir(parents=True, exist_ok=True)
                p.write_text(json.dumps(rec))
                print(f"{datetime.now(timezone.utc):%H:%M:%S} {s} {m} seed {k}: E {rec['E']:.3f} "
                      f"unsafe {rec['unsafe_flights']} s/it {rec['s_per_iter']:.3f} wall {rec['wall']:.0f}s",
                      file=log, flush=True)
                bar.update(tid, advance=1, description=f"{s} {m} {k}")


# ----------------------------------------------------------------------------------------------------- report
TUNING = ROOT / "benchmarks" / "campaign-tuning"  # runs on seeds 100+ (where defaults were chosen)


def load(setting: str, root: Path | None = None) -> dict[str, list[dict]]:
    out: dict[str, list[dict]] = {}
    for p in sorted(((root or OUT) / setting).glob("*.json")):
        rec = json.loads(p.read_text())
        out.setdefault(rec["method"], []).append(rec)
    return out


def med(v) -> str:
    """Median [min, max], ignoring NaN (J^Q of a recommendation whose every re-flight crashed), with NaN count."""
    v = np.asarray(v, float)
    ok = v[np.isfinite(v)]
    if ok.size == 0:
        return "n/a"
    extra = f" ({v.size - ok.size} n/a)" if ok.size < v.size else ""
    return f"{np.median(ok):.3f} [{ok.min():.3f}, {ok.max():.3f}]{extra}"


def medi(v) -> str:
    v = np.asarray(v, float)
    return f"{np.median(v):g} [{v.min():g}, {v.max():g}]"


def table(setting: str, runs: dict[str, list[dict]]) -> list[str]:
    lines = [
        "| method | seeds | re-flown E[P] | best observed P | re-flown J^Q | J^R improvement vs a0 | crashed re-flights | "
        "unsafe flights (counted) | seeds with 0 unsafe | prior unsafe (not counted) | s/iter | orders (runs) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for m in ALL_NAMES:
        if m not in runs:
            continue
        rs = runs[m]
        unsafe = [r["unsafe_flights"] if r["prior_counted"] else r["n_unsafe"] for r in rs]
        pu = [r["prior_unsafe"] for r in rs if not r["prior_counted"]]
        orders: dict[str, int] = {}
        for r in rs:
            if r["orders"]:
                key = ",".join(map(str, r["orders"]))
                orders[key] = orders.get(key, 0) + 1
        ostr = "; ".join(f"({k}) ×{v}" for k, v in sorted(orders.items(), key=lambda kv: -kv[1])) if orders else "–"
        lines.append(
            f"| {m} | {len(rs)} | {med([r['E'] for r in rs])} | {med([r['best_observed'] for r in rs])} | "
            f"{med([r['JQ'] for r in rs])} | {100 * np.nanmedian([r['JR_improvement'] for r in rs]):.1f} % | "
            f"{sum(r['crashed_reflights'] for r in rs)}/{8 * len(rs)} | {medi(unsafe)} | "
            f"{sum(u == 0 for u in unsafe)}/{len(rs)} | {medi(pu) if pu else '–'} | "
            f"{np.median([r['s_per_iter'] for r in rs]):.3f} | {ostr} |"
        )
    return lines


def paper_comparison(runs: dict[str, list[dict]]) -> list[str]:
    """The paper's claims (arXiv 2411.07573, fact sheet part A) next to what the paper-setting campaign measured."""
    def e(m: str) -> float:
        return float(np.median([r["E"] for r in runs[m]])) if m in runs else float("nan")

    def unsafe(m: str, after: int = 0) -> str:
        if m not in runs:
            return "n/a"
        v = [int(np.sum(np.asarray(r["y"][after:]) < 0)) for r in runs[m]]
        return f"median {np.median(v):g} [{min(v)}, {max(v)}]"

    orders: dict[str, int] = {}
    for r in runs.get("ksbo", []):
        key = ",".join(map(str, r["orders"] or []))
        orders[key] = orders.get(key, 0) + 1
    ostr = "; ".join(f"({k}) ×{v}" for k, v in sorted(orders.items(), key=lambda kv: -kv[1]))
    jr = np.nanmedian([r["JR_improvement"] for r in runs.get("ksbo", [])]) if "ksbo" in runs else float("nan")
    return [
        "| claim (paper) | paper | measured here (median over seeds, re-flown E[P]) |",
        "|---|---|---|",
        f"| selected orders | 2, 3, 4 | {ostr} |",
        f"| proposed method, final value | 81.06 (P scale undefined) | ksbo {e('ksbo'):.3f}; ksbo-234 {e('ksbo-234'):.3f} |",
        f"| orders 1 + 9 stay below the proposed method | never above 80 vs 81.06 | standard {e('standard'):.3f} |",
        f"| LineBO after 200 evaluations / proposed | 68.64 / 81.06 = 0.847 | linebo {e('linebo'):.3f} / ksbo "
        f"{e('ksbo'):.3f} = {e('linebo') / e('ksbo'):.3f} |",
        f"| unconstrained BO violates safety several times | yes | ucb unsafe {unsafe('ucb')}; ei {unsafe('ei')} "
        f"(of 150) |",
        f"| proposed: no unsafe point after 20 iterations | yes | ksbo unsafe after iteration 20: "
        f"{unsafe('ksbo', 20)} |",
        f"| J^R improvement from the default gains | 42.75 % | ksbo {100 * jr:.1f} % |",
    ]


def curves(rs: list[dict], key: str = "flights") -> tuple[np.ndarray, np.ndarray]:
    n = min(len(r[key]) for r in rs)
    Y = np.array([np.maximum.accumulate(np.asarray(r[key][:n])) for r in rs])
    U = np.array([np.cumsum(np.asarray(r[key][:n]) < 0) for r in rs])
    return Y, U


def figures(setting: str, runs: dict[str, list[dict]]) -> list[str]:
    from ksbo_mav.plotting import pyplot

    plt = pyplot()
    FIG.mkdir(parents=True, exist_ok=True)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.5))
    for m in ALL_NAMES:
        if m not in runs:
            continue
        Y, U = curves(runs[m])
        x = np.arange(1, Y.shape[1] + 1)
        line, = a1.plot(x, np.median(Y, 0), label=m)
        a1.fill_between(x, np.percentile(Y, 25, 0), np.percentile(Y, 75, 0), color=line.get_color(), alpha=0.15)
        a2.plot(x, np.median(U, 0), color=line.get_color(), label=m)
        a2.fill_between(x, U.min(0), U.max(0), color=line.get_color(), alpha=0.1)
    a1.set(xlabel="flights (counted)", ylabel="best observed P (median, IQR)", ylim=(-0.2, 1.0),
           title=f"{setting}: convergence")
    a2.set(xlabel="flights (counted)", ylabel="cumulative unsafe flights (median, min–max)",
           title=f"{setting}: unsafe evaluations")
    a1.axhline(0.966, ls=":", c="k", lw=0.8)
    a1.legend(fontsize=8)
    fig.tight_layout()
    p = FIG / f"campaign_{setting}.png"
    fig.savefig(p, dpi=110)
    plt.close(fig)
    return [str(p.relative_to(ROOT))]


def trajectory_figure(runs: dict[str, list[dict]]) -> str | None:
    """Initial (a0) vs tuned (median-E ksbo run of the vehicle setting) trajectory on the first fixed init."""
    if "ksbo" not in runs:
        return None
    from ksbo_mav.objective import SimObjective
    from ksbo_mav.plotting import plot_trajectories
    from ksbo_mav.profiles import load_profile
    from ksbo_sim.episode import fixed_initial_states

    rs = sorted(runs["ksbo"], key=lambda r: r["E"])
    r = rs[len(rs) // 2]
    prof = load_profile("sim-planar")
    obj = SimObjective(prof, seed=0)
    init = fixed_initial_states(config=obj.episode)[0]
    f0 = obj.fly(prof.default, init=init)
    f1 = obj.fly(np.asarray(r["x"]), init=init)
    p = FIG / "campaign_trajectory.png"
    plot_trajectories([f0.trajectory, f1.trajectory],
                      [f"initial a0 (P={f0.P:.3f})", f"ksbo seed {r['seed']} (P={f1.P:.3f})"], p,
                      title="Figure-8: initial vs tuned gains (vehicle-safe setting)")
    return str(p.relative_to(ROOT))


def overhead(n_obs: int = 200, repeats: int = 5) -> dict[str, float]:
    """Seconds per ksbo proposal with ``n_obs`` observations (9-D, orders 2, 3, 4, campaign options, 1 thread)."""
    from threadpoolctl import threadpool_limits

    from ksbo_mav.opt.options import options_for
    from ksbo_mav.opt.problem import Problem
    from ksbo_mav.opt.safe_methods import _build

    with threadpool_limits(1):
        rng = np.random.default_rng(0)
        X = np.clip(0.3 + 0.2 * rng.random((n_obs, 9)), 0, 1)
        y = np.sin(3 * X).sum(1) / 3
        opts = options_for("ksbo", METHOD_OPTIONS["ksbo"]).update({"expansion_iters": 0})
        prob = Problem(fun=lambda x: 0.0, lower=np.zeros(9), upper=np.ones(9), x0=X[0], budget=1)
        bo = _build(prob, opts, (2, 3, 4), None, 0, rng)
        bo.fit(X, y)
        t = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            p = bo.propose()
            t.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        bo.observe(p.x, 0.5)
        return {"ksbo": float(np.median(t)), "ksbo_update": time.perf_counter() - t0}


def report(args) -> None:
    lines = [SECTION, "",
             f"Machine: {machine()}. Script: `python scripts/bench_campaign.py` "
             "(2 worker processes, BLAS pinned to 1 thread; JSON per run in `benchmarks/campaign/`).",
             "",
             "Re-flown E[P] / J^Q = recommendation re-flown over the 8 fixed initial conditions (median [min, max] "
             "over seeds). Unsafe = P < 0. s/iter = optimiser time per evaluation, simulator excluded.",
             f"Options: `{json.dumps(METHOD_OPTIONS)}`; ksbo's library defaults differ from the other safe "
             "methods in `max_order` 4 (orders selected among 1..4) and `beta` 5 (`opt.options.METHOD_DEFAULTS`). "
             "Variants: " + "; ".join(f"`{k}` = {m} with `{json.dumps(o)}`" for k, (m, o) in VARIANTS.items()) + ".",
             ""]
    for setting, title in (("vehicle", "Vehicle-safe setting: a0 + local prior, 100 flights in total"),
                           ("paper", "Paper setting: 36-point uniform LHS prior + 150 evaluations (LineBO 200)")):
        runs = load(setting)
        if not runs:
            continue
        lines += [f"### {title}", ""]
        if setting == "vehicle":
            r0 = next(iter(runs.values()))[0]
            lines += [f"Local prior: {r0['n_prior']} LHS points within ±{args.local_radius} (unit cube) of a0, "
                      "flown and counted in the 100 flights and in the unsafe column.", ""]
        lines += table(setting, runs) + [""]
        if setting == "paper":
            lines += ["Paper's comparisons side by side:", ""] + paper_comparison(runs) + [""]
        for f in figures(setting, runs):
            lines += [f"![{setting}]({f})", ""]
        if setting == "vehicle":
            t = trajectory_figure(runs)
            if t:
                lines += [f"![trajectory]({t})", ""]
    ov = overhead()
    veh, pap = load("vehicle"), load("paper")
    if veh.get("ksbo") or pap.get("ksbo"):
        lines += ["Goals of issue 5 (computed from the runs above):", ""]
        for name in ("ksbo", "ksbo-234"):
            rs = veh.get(name, [])
            if rs:
                zero = sum(r["unsafe_flights"] == 0 for r in rs)
                e = float(np.median([r["E"] for r in rs]))
                lines.append(f"- vehicle-safe, {name}: median re-flown E[P] {e:.3f} (goal ≥ 0.95: "
                             f"{'met' if e >= 0.95 else 'not met'}); 0 unsafe flights in {zero}/{len(rs)} seeds "
                             f"(goal ≥ 9/10: {'met' if zero >= 0.9 * len(rs) else 'not met'}).")
        if pap.get("ksbo"):
            ek = float(np.median([r["E"] for r in pap["ksbo"]]))
            others = {m: float(np.median([r["E"] for r in pap[m]])) for m in ("standard", "linebo", "ucb", "ei")
                      if m in pap}
            ahead = all(ek > v for v in others.values())
            lines.append(f"- paper setting: ksbo {ek:.3f} vs " + ", ".join(f"{m} {v:.3f}" for m, v in others.items())
                         + f" — ksbo ahead of all: {'yes' if ahead else 'no'}.")
        lines.append(f"- optimiser overhead at 200 observations: {ov['ksbo']:.3f} s per iteration (goal ≤ 0.2 s: "
                     f"{'met' if ov['ksbo'] <= 0.2 else 'not met'}).")
        lines.append("")
        tuning = load("vehicle", TUNING)
        if tuning:
            lines += ["Tuning seeds (vehicle-safe, seeds 100+, where the defaults were chosen; "
                      "`--seed-offset 100 --seeds 50 --out benchmarks/campaign-tuning`):", ""]
            lines += table("vehicle", tuning) + [""]
        lines += [
            "Observations:",
            "",
            "- Defaults chosen in the last round on seeds 100+ (never on the reported seeds 0–9): SE safety GP "
            "lengthscale 0.05 (was 0.07), the last 20 evaluations maximise the posterior mean inside the certified "
            "set, and candidates grow from x0 (`explore_from=\"x0\"`: clouds around the start and the "
            "optimiser's own evaluations, prior points join once within 0.1, no global Sobol points). "
            "`ksbo-prev` is ksbo with the previous defaults. With them the vehicle-safe ksbo row was 0.901 "
            "[0.866, 0.924], 0 unsafe in 7/10, and in the paper setting all safe methods tied at ≈ 0.355: under a "
            "safety bound β the certified edge of a region with mean μ has σ ≤ μ/β, so UCB there is at most "
            "μ(1 + β_ucb/β) and a flat prior plateau at P ≈ 0.3–0.4 (chattering pitch loop, 1.0–1.5 from a0) "
            "outbid the steep slope that starts at a0's 0.2 for the whole budget.",
            "- Speed against safety (vehicle-safe): every setting that travels further from a0 crashes more — "
            "`ksbo-fast` (safety lengthscale 0.14) against `ksbo-prev` against ksbo in the tables above. Also tried "
            "on seeds 100–109/119 and dropped (no gain in both E[P] and safety): β 3/4/6, acquisition β 0–3, "
            "prior std 0.5, additive lengthscale 0.2, noise ratio 0.1, candidates on lines along the mean's "
            "gradient, a cap on the step from the nearest safe observation, a pessimistic (μ − σ) exploitation, and "
            "per-dimension safety lengthscales fitted by ML-II within [0.05, 0.1] or [0.05, 0.2] every 5 "
            "iterations (0.906 / 0.903, but unsafe flights in 14 and 15 of 20 seeds).",
            "- Why ≥ 0.95 is out of reach here: see the section *Planar task landscape around a0* — the best "
            "E[P] within 0.3 of a0 (unit cube) is 0.916, 0.946 within 0.5, 0.961 within 0.8; the ≥ 0.95 gains "
            "near the straight way there have 4–18 % crashing neighbours at distance 0.03, and the ≥ 0.95 gains "
            "with a crash-free 0.03-ball lie 0.77–1.08 from a0. After 100 flights ksbo's recommendations lie "
            "0.17–0.27 from a0 (ksbo-prev 0.17–0.39, ksbo-fast 0.14–0.65, seeds 0–9 and 100–149).",
            "- The late unsafe flights of the safe methods come 0.03–0.08 (unit cube) from gains with P ≈ 0.9 and "
            "re-fly with 2–8 of 8 initial conditions crashing: bistable gains (part D), not a calibration bug. "
            "`ksbo-nosafetygp` (the additive GP alone certifies safety) has many more unsafe flights than ksbo.",
            "- One paper-setting ksbo seed re-flies at 0.44 although its recommendation flew 0.92: a point whose "
            "pitch loop chatters for some initial conditions (0 crashed re-flights, low P). Unconstrained BO finds "
            "high single episodes but its recommendations re-fly poorly.",
            "",
        ]
    lines += [f"Optimiser overhead at 200 observations (9-D, orders 2, 3, 4, one proposal incl. candidates and "
              f"refinement, 1 thread): {ov['ksbo']:.3f} s; rank-one model update {ov['ksbo_update'] * 1e3:.1f} ms.",
              ""]
    (OUT / "summary.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    if args.no_bench_md:
        return
    write_section(SECTION.removeprefix("## "), "\n".join(lines[2:]))


def main(argv: list[str] | None = None) -> int:
    global OUT
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--settings", nargs="+", default=["vehicle", "paper"], choices=["vehicle", "paper"])
    ap.add_argument("--methods", nargs="+", default=list(ALL_METHODS), choices=ALL_NAMES)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--seed-offset", type=int, default=0, help="first seed (use e.g. 100 for tuning runs)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--local-n", type=int, default=8, help="vehicle setting: local LHS prior size (counted)")
    ap.add_argument("--local-radius", type=float, default=0.01)
    ap.add_argument("--report", action="store_true", help="only aggregate existing runs")
    ap.add_argument("--out", type=Path, default=OUT, help="directory of the per-run JSON files")
    ap.add_argument("--no-bench-md", action="store_true", help="do not touch BENCHMARKS.md")
    args = ap.parse_args(argv)
    OUT = args.out.resolve()
    OUT.mkdir(parents=True, exist_ok=True)
    if not args.report:
        run_campaign(args)
    report(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
