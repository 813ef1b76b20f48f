"""Diagnostic: how high can a planar plant's E[P] be driven from a0 without ever stepping onto gains that
fail, when flights are free?

A (1+λ) evolution strategy in the optimiser's unit cube, started at a0. Each generation draws λ gains around the
current point (Gaussian, step σ); a candidate counts as safe only if it completes with P ≥ 0 from every one of
the plant's 8 fixed initial conditions and 24 more random ones (seeded), strict (the plant's own score, no
monitor). The best safe candidate is taken if it raises the mean P over those 32 starts; σ grows ×1.2 after a step
and shrinks ×0.8 after a generation without one. Every accepted point is safe from all 32 starts, so the path it
draws is a chain of safe gains from a0 (steps of a few hundredths of the unit cube once σ has shrunk) — a
yardstick for the safe optimisers, which must find such a path with one flight per trial, and a source of the
"best known" E[P] per plant. The end point is then flown from 200 further random starts.

It flies λ × 32 episodes per generation (48 × 32; a run stops after 40–80 generations, when σ < 0.003: about
100 000 episodes, a minute or two on one core).

    python scripts/diag/safe_climb.py --plants nominal --seeds 0-3
    python scripts/diag/safe_climb.py --plants all --seeds 0-1 --out benchmarks/plants/safe-climb.jsonl
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from ksbo_bench.sweep import parse_ints as _seeds

OUT = Path(__file__).resolve().parent.parent / "benchmarks" / "plants" / "safe-climb.jsonl"
N_RANDOM, CHECK_STARTS = 24, 200


class Climb:
    """The safe (1+λ) climb on one plant; :meth:`run` returns its record."""

    def __init__(self, plant: str, seed: int, lam: int = 48, sigma: float = 0.04, generations: int = 120,
                 n_random: int = N_RANDOM):
        from ksbo_mav.simulated.planar_objective import SimObjective
        from ksbo_task.starts import fixed_initial_states, random_initial_states

        self.obj = SimObjective(plant=plant, monitor=False)
        self.plant, self.seed, self.lam, self.sigma0, self.generations = plant, seed, lam, sigma, generations
        fixed = fixed_initial_states(figure8=self.obj.episode.figure8)
        figure8 = self.obj.episode.figure8
        self.inits = np.vstack([fixed, random_initial_states(n_random, np.random.default_rng(777), figure8)])
        self.check = random_initial_states(CHECK_STARTS, np.random.default_rng(4242), self.obj.episode.figure8)
        self.episodes = 0

    def evaluate(self, U: np.ndarray, inits: np.ndarray | None = None) -> np.ndarray:
        """P of each unit-cube point of U (n, d) from each start: (n, m)."""
        inits = self.inits if inits is None else inits
        X = np.array([self.obj.profile.from_unit(np.clip(u, 0.0, 1.0)) for u in U])
        n, m = len(X), len(inits)
        self.episodes += n * m
        return self.obj.scores(np.repeat(X, m, axis=0), np.tile(inits, (n, 1))).P.reshape(n, m)

    def run(self, log=print) -> dict:
        rng = np.random.default_rng(self.seed)
        a0 = self.obj.profile.to_unit(self.obj.profile.default)
        u, sigma, t0 = a0.copy(), self.sigma0, time.time()
        P = self.evaluate(u[None])[0]
        if P.min() < 0:
            raise SystemExit(f"{self.plant}: a0 itself fails from one of the starts (min P {P.min():.3f})")
        score, path, stall = P.mean(), [(0, self.episodes, float(P[:8].mean()), u.round(4).tolist())], 0
        for gen in range(1, self.generations + 1):
            U = np.clip(u + sigma * rng.standard_normal((self.lam, u.size)), 0.0, 1.0)
            Ps = self.evaluate(U)
            value = np.where(Ps.min(axis=1) >= 0, Ps.mean(axis=1), -np.inf)
            j = int(np.argmax(value))
            if value[j] > score + 1e-5:
                u, P, score, sigma, stall = U[j], Ps[j], value[j], min(sigma * 1.2, 0.15), 0
                path.append((gen, self.episodes, float(P[:8].mean()), u.round(4).tolist()))
            else:
                sigma, stall = sigma * 0.8, stall + 1
            if gen % 10 == 0:
                log(f"  {self.plant} seed {self.seed} gen {gen}: E[P] (8 fixed) {P[:8].mean():.4f}, "
                    f"{len(self.inits)} starts {score:.4f}, σ {sigma:.3f}, {np.linalg.norm(u - a0):.2f} from a0")
            if sigma < 0.003:
                break
        check = self.evaluate(u[None], self.check)[0]
        return {"plant": self.plant, "seed": self.seed, "EP": float(P[:8].mean()), "EP32": float(score),
                "minP32": float(P.min()), "x": self.obj.profile.from_unit(u).tolist(), "u": u.round(4).tolist(),
                "from_a0": float(np.linalg.norm(u - a0)), "generations": gen, "steps": len(path) - 1,
                "episodes": self.episodes, "check_EP": float(check.mean()), "check_fail": int((check < 0).sum()),
                "check_starts": CHECK_STARTS, "lam": self.lam, "starts": len(self.inits),
                "wall_s": round(time.time() - t0, 1), "path": path}


def main(argv: list[str] | None = None) -> None:
    from ksbo_sim.plants import PLANTS

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--plants", default="nominal", help="comma-separated planar plants, or 'all'")
    ap.add_argument("--seeds", default="0")
    ap.add_argument("--lam", type=int, default=48, help="candidates per generation")
    ap.add_argument("--random-starts", type=int, default=N_RANDOM,
                    help="random starts besides the 8 fixed ones that a candidate must complete from")
    ap.add_argument("--out", default=None, help=f"JSON lines to append to (e.g. {OUT.relative_to(OUT.parents[2])})")
    a = ap.parse_args(argv)
    plants = list(PLANTS) if a.plants == "all" else [p.strip() for p in a.plants.split(",")]
    for plant in plants:
        for seed in _seeds(a.seeds):
            rec = Climb(plant, seed, lam=a.lam, n_random=a.random_starts).run()
            reach = next((p[1] for p in rec["path"] if p[2] >= 0.95), None)
            print(f"{plant:12s} seed {seed}: E[P] {rec['EP']:.4f} ({rec['starts']} starts {rec['EP32']:.4f}, "
                  f"min {rec['minP32']:.3f}),"
                  f" {rec['from_a0']:.2f} from a0 in {rec['steps']} steps / {rec['generations']} generations; "
                  f"{CHECK_STARTS} random starts: {rec['check_EP']:.4f}, {rec['check_fail']} with P < 0; "
                  f"{rec['wall_s']:.0f} s; E[P] ≥ 0.95 after {reach} episodes", flush=True)
            if a.out:
                with open(a.out, "a") as f:
                    f.write(json.dumps(rec) + "\n")


if __name__ == "__main__":
    main()
