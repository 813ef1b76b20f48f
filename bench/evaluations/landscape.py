"""Evaluation ``landscape``: where the good gains of the planar task lie, seen from the default gains a0 (how far a
safe optimiser from a0 must travel). In the unit cube of the sim-planar profile, a gain vector's value is its
re-flown E[P] (8 fixed initial conditions). ``measure``:

- ``reach`` (``R``): the best E[P] a (1+200) evolution strategy (60 rounds, ``seed``) finds within distance R of
  a0; with ``risk = true`` also the risk along the straight line from a0 to it: E[P] at six points and the share
  of 200 random neighbours at distance 0.03 and 0.06 whose E[P] is negative (one crashing initial condition in 8
  makes the mean negative only if it crashes early: this undercounts single-episode risk);
- ``robust`` (``seed``): the best E[P] whose 0.03-ball showed no crashing episode in 64 random (neighbour,
  initial velocity) draws when accepted (80 rounds): an upper bound for an optimiser that must not crash while it
  takes steps of that size.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from ksbo_bench.cell_errors import SweepError


def check(key: dict[str, Any]) -> None:
    if key.get("measure") not in ("reach", "robust"):
        raise SweepError("landscape: measure must be reach (with R) or robust")


def es_max(E: Callable, u0: np.ndarray, rng: np.random.Generator, radius: float, iters: int = 60,
           accept: Callable | None = None) -> tuple[float, np.ndarray]:
    """(1+λ) evolution strategy on ``E`` (batch of unit-cube points -> values) within ``radius`` of ``u0``;
    ``accept(u) -> bool`` is an extra constraint checked on the best few candidates of each round."""
    best, fb = u0.copy(), float(E(u0[None])[0])
    for it in range(iters):
        T = np.clip(best + rng.standard_normal((200, u0.size)) * 0.1 * 0.97**it, 0, 1)
        T = T[np.linalg.norm(T - u0, axis=1) <= radius]
        if len(T) == 0:
            continue
        f = E(T)
        for j in np.argsort(-f)[:6]:
            if f[j] <= fb:
                break
            if accept is None or accept(T[j]):
                fb, best = float(f[j]), T[j].copy()
                break
    return fb, best


def run(key: dict[str, Any]) -> dict[str, Any]:
    from ksbo_mav.profiles import load_profile
    from ksbo_mav.simulated.planar_objective import SimObjective
    from ksbo_task.starts import random_initial_states

    prof = load_profile("sim-planar")
    obj = SimObjective(prof, seed=0)
    u0 = prof.to_unit(prof.default)
    seed = int(key.get("seed", 0))

    def E(U: np.ndarray) -> np.ndarray:
        return obj.expected(prof.from_unit(np.clip(U, 0, 1)))

    if key["measure"] == "robust":
        rng = np.random.default_rng(1000 + seed)

        def crash_free(u: np.ndarray, r: float = 0.03, n: int = 64) -> bool:
            D = rng.standard_normal((n, u.size))
            D /= np.linalg.norm(D, axis=1, keepdims=True)
            N = np.clip(u + r * rng.random((n, 1)) ** (1 / u.size) * D, 0, 1)
            starts = random_initial_states(n, rng, obj.episode.figure8)
            return bool(np.all(obj.scores(prof.from_unit(N), starts).P >= 0))

        fb, ub = es_max(E, u0, np.random.default_rng(100 + seed), 2.0, iters=80, accept=crash_free)
        return {"EP": fb, "distance": float(np.linalg.norm(ub - u0)), "u": np.round(ub, 3).tolist()}
    rng = np.random.default_rng(seed)
    R = float(key["R"])
    fb, ub = es_max(E, u0, rng, R)
    out: dict[str, Any] = {"EP": fb, "distance": float(np.linalg.norm(ub - u0)), "u": np.round(ub, 4).tolist(),
                           "EP_a0": float(E(u0[None])[0])}
    if key.get("risk"):
        line = []
        for t in np.linspace(0.0, 1.0, 6):
            u = u0 + t * (ub - u0)
            share = []
            for r in (0.03, 0.06):
                D = rng.standard_normal((200, u.size))
                D /= np.linalg.norm(D, axis=1, keepdims=True)
                share.append(float(np.mean(E(u + r * D) < 0)))
            line.append({"t": float(t), "EP": float(E(u[None])[0]), "unsafe_003": share[0], "unsafe_006": share[1]})
        out["line"] = line
    return out


def report(recs: list[dict[str, Any]]) -> str:
    reach = sorted((r for r in recs if r["key"]["measure"] == "reach"), key=lambda r: r["key"]["R"])
    robust = sorted((r for r in recs if r["key"]["measure"] == "robust"), key=lambda r: r["key"].get("seed", 0))
    out = ["**Reach**: best E[P] within distance R of a0 (a0 itself: "
           f"{reach[0]['result']['EP_a0']:.3f})" if reach else "", "", "| R | best E[P] | its distance from a0 |",
           "|---|---|---|", *(f"| {r['key']['R']:g} | {r['result']['EP']:.3f} | {r['result']['distance']:.2f} |"
                              for r in reach)]
    lines = [r for r in reach if r["result"].get("line")]
    if lines:
        out += ["", "**Risk along the way**: the straight line from a0 to the reach point; share of 200 random "
                "neighbours at distance r with E[P] < 0", "", "| line | t | E[P] | unsafe neighbours r = 0.03 | "
                "r = 0.06 |", "|---|---|---|---|---|"]
        out += [f"| a0 → R {r['key']['R']:g} | {p['t']:.1f} | {p['EP']:.3f} | {p['unsafe_003']:.2f} | "
                f"{p['unsafe_006']:.2f} |" for r in lines for p in r["result"]["line"]]
    if robust:
        out += ["", "**Robust optimum**: best E[P] whose 0.03-ball showed no crash in 64 random draws", "",
                "| restart | E[P] | distance from a0 | gains (unit cube) |", "|---|---|---|---|"]
        out += [f"| {r['key'].get('seed', 0)} | {r['result']['EP']:.3f} | {r['result']['distance']:.2f} | "
                f"{r['result']['u']} |" for r in robust]
    return "\n".join(x for x in out).strip()
