"""Position/velocity estimator: a filterpy Kalman filter over noisy simulated sensors, as an autopilot's EKF.

Per NED axis the state is [position, velocity]. The prediction is driven by the accelerometer (true
acceleration + white noise, std ``acc_noise``); the update fuses a position and a velocity measurement
(GPS / vision-like, stds ``pos_noise`` and ``vel_noise``). With all three noise levels zero the filter is
bypassed and the estimate *is* the truth, bit for bit (zero-noise mode for exact tests).
"""

from __future__ import annotations

import numpy as np
from filterpy.kalman import KalmanFilter

_FLOOR = 1e-6  # keeps the covariances invertible when only some sensors are noisy


class Estimator:
    def __init__(self, dt: float, pos_noise: float = 0.0, vel_noise: float = 0.0, acc_noise: float = 0.0,
                 seed: int | None = None) -> None:
        self.dt = dt
        self.rng = np.random.default_rng(seed)
        self.kf: KalmanFilter | None = None
        self.configure(pos_noise, vel_noise, acc_noise)

    @property
    def exact(self) -> bool:
        return self.pos_noise == 0.0 and self.vel_noise == 0.0 and self.acc_noise == 0.0

    def configure(self, pos_noise: float, vel_noise: float, acc_noise: float) -> None:
        """Change the noise levels (parameters SIM_POS_NOISE, SIM_VEL_NOISE, SIM_ACC_NOISE)."""
        self.pos_noise, self.vel_noise, self.acc_noise = float(pos_noise), float(vel_noise), float(acc_noise)
        dt = self.dt
        f1 = np.array([[1.0, dt], [0.0, 1.0]])
        b1 = np.array([[0.5 * dt * dt], [dt]])
        kf = KalmanFilter(dim_x=6, dim_z=6, dim_u=3)
        kf.F = np.kron(np.eye(3), f1)
        kf.B = np.kron(np.eye(3), b1)
        kf.H = np.eye(6)
        sa, sp, sv = max(self.acc_noise, _FLOOR), max(self.pos_noise, _FLOOR), max(self.vel_noise, _FLOOR)
        kf.Q = np.kron(np.eye(3), b1 @ b1.T) * sa * sa
        kf.R = np.diag(np.tile([sp * sp, sv * sv], 3))
        kf.P = np.diag(np.tile([sp * sp, sv * sv], 3))
        if self.kf is not None:
            kf.x = self.kf.x.copy()
            if getattr(self, "_truth", None) is not None:
                kf.x = np.stack(self._truth, axis=1).reshape(6, 1).astype(float)
        self._truth = None
        self.kf = kf

    def reset(self, pos: np.ndarray, vel: np.ndarray) -> None:
        """Re-initialise on the true state (boot, teleport, landing)."""
        self.kf.x = np.stack([pos, vel], axis=1).reshape(6, 1).astype(float)
        self.kf.P = self.kf.R.copy()
        self._truth = None

    def update(self, pos: np.ndarray, vel: np.ndarray, acc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One control period: predict with the noisy accelerometer, correct with noisy pos/vel.

        Args: true position, velocity and mean acceleration over the period (NED). Returns the estimate (in
        zero-noise mode the very arrays passed in: callers must not modify them).
        """
        if self.exact:
            self._truth = (pos, vel)  # kept so switching noise on mid-flight starts from the truth
            return pos, vel
        r = self.rng
        u = (acc + r.normal(0.0, self.acc_noise, 3)).reshape(3, 1)
        z = np.stack([pos + r.normal(0.0, self.pos_noise, 3), vel + r.normal(0.0, self.vel_noise, 3)], axis=1)
        self.kf.predict(u=u)
        self.kf.update(z.reshape(6, 1))
        x = self.kf.x.reshape(3, 2)
        return x[:, 0].copy(), x[:, 1].copy()
