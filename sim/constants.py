"""Physical and actuator constants of Safe Control Gym's Crazyflie 2.x (cf2x.urdf, controllers/pid/pid.yaml)."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class QuadConstants:
    """Constants of the planar (x-z) quadrotor and its PWM motor model.

    Each planar input T1, T2 is the thrust of one *pair* of motors (SCG's 2-D reduction), so
    T = 2 * kf * rpm**2 with rpm = pwm2rpm_scale * pwm + pwm2rpm_const.
    """

    mass: float = 0.027  # kg
    iyy: float = 1.4e-5  # kg m^2
    arm: float = 0.0397  # m, motor distance from the centre
    g: float = 9.8  # m/s^2
    kf: float = 3.16e-10  # N / rpm^2
    pwm2rpm_scale: float = 0.2685
    pwm2rpm_const: float = 4070.3
    pwm_min: float = 20000.0
    pwm_max: float = 65535.0
    max_torque_pwm: float = 3200.0  # torque clip of SCG's attitude PID, in PWM units
    pos_integral_limit_x: float = 2.0
    pos_integral_limit_z: float = 0.15
    pitch_integral_limit: float = 1.0

    @property
    def moment_arm(self) -> float:
        """d = l / sqrt(2): lever arm of the motor pairs about the pitch axis of an X frame."""
        return self.arm / math.sqrt(2.0)

    def pair_thrust(self, pwm: float) -> float:
        """Thrust (N) of one motor pair at a given PWM command."""
        rpm = self.pwm2rpm_scale * pwm + self.pwm2rpm_const
        return 2.0 * self.kf * rpm * rpm

    @property
    def thrust_min(self) -> float:
        return self.pair_thrust(self.pwm_min)

    @property
    def thrust_max(self) -> float:
        return self.pair_thrust(self.pwm_max)

    @property
    def hover_thrust(self) -> float:
        """Thrust per motor pair that balances gravity (N)."""
        return self.mass * self.g / 2.0


SCG_CRAZYFLIE = QuadConstants()
