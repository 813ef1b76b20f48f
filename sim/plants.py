"""Plant variants of the planar task: the same controller (tuned on nominal constants) flying a different vehicle.

A :class:`Plant` changes the *true* vehicle while the PID keeps the nominal constants it was written for (its
hover feed-forward ``m g`` and its PWM → thrust map): a heavier vehicle, a weaker motor, a lagging or delayed
actuator, noisy state estimates, wind gusts. :data:`PLANTS` is the benchmark suite.

Noise and gusts are random per episode but deterministic: each episode's generator is seeded from the plant's
``seed`` and the bytes of its initial state, so a row's result never depends on the batch it flies in and
re-flying the fixed initial conditions is reproducible.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field, replace

import numpy as np

from ksbo_sim.constants import SCG_CRAZYFLIE, QuadConstants


@dataclass(frozen=True)
class Plant:
    """The true vehicle and its imperfections.

    Attributes:
        name: label.
        mass_factor, iyy_factor: true mass / pitch inertia relative to the controller's constants.
        thrust_factor: true thrust per commanded thrust (thrust coefficient kf factor; 0.8 = −20 %).
        motor_tau: first-order motor time constant (s); 0 = instantaneous.
        delay_steps: control periods between the controller's command and the motors (1 step = 20 ms at 50 Hz).
        noise_std: (6,) std of additive white noise on the state the controller sees [x, vx, z, vz, θ, θ̇].
        gust_accel: peak horizontal / vertical gust acceleration (m/s²); 0 = calm.
        gust_period: mean duration of a gust (s).
        seed: base seed of the per-episode noise and gust generators.
        j_hi: J^Q scale of this plant's score (P = 1 − J^Q/j_hi for a complete flight): 1.25 × the worst J^Q of
            the baseline a0 over 200 random initial velocities (seed 7), so a0 is safe (P > 0) on every plant;
            nominal keeps the task's 5.6.
    """

    name: str = "nominal"
    mass_factor: float = 1.0
    iyy_factor: float = 1.0
    thrust_factor: float = 1.0
    motor_tau: float = 0.0
    delay_steps: int = 0
    noise_std: tuple[float, ...] = (0.0,) * 6
    gust_accel: tuple[float, float] = (0.0, 0.0)
    gust_period: float = 1.0
    seed: int = 0
    j_hi: float = 5.6

    def constants(self, nominal: QuadConstants = SCG_CRAZYFLIE) -> QuadConstants:
        """The true vehicle's constants (the controller keeps ``nominal``)."""
        return replace(nominal, mass=nominal.mass * self.mass_factor, iyy=nominal.iyy * self.iyy_factor)

    @property
    def is_nominal(self) -> bool:
        return self == Plant(name=self.name, seed=self.seed, j_hi=self.j_hi)

    def _rng(self, init_row: np.ndarray) -> np.random.Generator:
        h = hashlib.blake2b(np.ascontiguousarray(init_row, dtype=float).tobytes(), digest_size=8).digest()
        return np.random.default_rng([self.seed, int.from_bytes(h, "little")])

    def disturbances(self, init: np.ndarray, steps: int, dt: float) -> tuple[np.ndarray | None, np.ndarray | None]:
        """Per-episode sensor noise (B, steps, 6) and gust accelerations (B, steps, 2) or None when absent.

        Gusts are "1 − cos" pulses of random sign, amplitude U(0.5, 1) × ``gust_accel`` and duration around
        ``gust_period``, separated by calm spells of similar length.
        """
        noisy = any(s > 0 for s in self.noise_std)
        gusty = any(a > 0 for a in self.gust_accel)
        if not (noisy or gusty):
            return None, None
        B = init.shape[0]
        noise = np.zeros((B, steps, 6)) if noisy else None
        gust = np.zeros((B, steps, 2)) if gusty else None
        for b in range(B):
            rng = self._rng(init[b])
            if noise is not None:
                noise[b] = rng.standard_normal((steps, 6)) * np.asarray(self.noise_std, dtype=float)
            if gust is not None:
                gust[b] = _gusts(rng, steps, dt, self.gust_accel, self.gust_period)
        return noise, gust


def _gusts(rng: np.random.Generator, steps: int, dt: float, peak: tuple[float, float], period: float) -> np.ndarray:
    out = np.zeros((steps, 2))
    k = int(rng.integers(0, max(1, int(period / dt))))
    while k < steps:
        n = max(2, int(rng.uniform(0.5, 1.5) * period / dt))
        shape = 0.5 * (1.0 - np.cos(2.0 * np.pi * np.arange(n) / n))
        amp = rng.uniform(0.5, 1.0, 2) * np.asarray(peak, dtype=float) * rng.choice([-1.0, 1.0], 2)
        m = min(n, steps - k)
        out[k : k + m] += shape[:m, None] * amp[None, :]
        k += n + int(rng.uniform(0.5, 1.5) * period / dt)
    return out


#: Estimate noise of a Crazyflie-class estimator (m, m/s, rad, rad/s); "noise x3" flies with three times this.
BASE_NOISE = (0.002, 0.01, 0.002, 0.01, 0.002, 0.02)

#: The benchmark suite: nominal and the variants, by name.
PLANTS: dict[str, Plant] = {
    p.name: p
    for p in (
        Plant("nominal"),
        Plant("mass+30", mass_factor=1.3, j_hi=14.65),
        Plant("mass-30", mass_factor=0.7, j_hi=6.25),
        Plant("iyy x0.5", iyy_factor=0.5, j_hi=21.12),
        Plant("iyy x2", iyy_factor=2.0, j_hi=3.06),
        Plant("thrust-20", thrust_factor=0.8, j_hi=8.37),
        Plant("motor lag", motor_tau=0.03, j_hi=5.26),
        Plant("delay 40ms", delay_steps=2, j_hi=39.56),
        Plant("noise x3", noise_std=tuple(3 * s for s in BASE_NOISE), j_hi=8.14),
        Plant("gusts", gust_accel=(1.5, 1.0), gust_period=1.0, j_hi=12.15),
    )
}


def plant(name: str) -> Plant:
    """Suite plant by name (KeyError lists the known names)."""
    try:
        return PLANTS[name]
    except KeyError:
        raise KeyError(f"unknown plant {name!r}; known: {', '.join(PLANTS)}") from None


@dataclass
class ActuatorState:
    """Delay line and motor-lag state of a batch (B rows) during an episode."""

    plant: Plant
    dt: float
    queue: list[np.ndarray] = field(default_factory=list)
    thrust: np.ndarray | None = None

    def apply(self, cmd: np.ndarray) -> np.ndarray:
        """(B, 2) commanded pair thrusts → (B, 2) thrusts the plant feels this period."""
        p = self.plant
        if p.delay_steps > 0:
            self.queue.append(cmd)
            cmd = self.queue.pop(0) if len(self.queue) > p.delay_steps else self.queue[0]
        if p.motor_tau > 0:
            a = 1.0 - np.exp(-self.dt / p.motor_tau)
            self.thrust = cmd.copy() if self.thrust is None else self.thrust + a * (cmd - self.thrust)
            cmd = self.thrust
        return cmd * p.thrust_factor

    def select(self, keep: np.ndarray) -> None:
        """Keep only rows ``keep`` (bool (B,)) after some episodes ended."""
        self.queue = [q[keep] for q in self.queue]
        if self.thrust is not None:
            self.thrust = self.thrust[keep]
