"""JSBSim physics for the DJI F450 quadrotor shipped in the jsbsim wheel (``aircraft/F450``).

The FDM is loaded once and re-used: :meth:`F450Backend.reset` goes back to the initial conditions with
``reset_to_initial_conditions(0)`` (re-running ``run_ic()`` does not reset the propeller/engine states).

Motor commands. The shipped ``FlightControl.xml`` feeds ``fcs/throttle-cmd-norm`` (= index 0) to *all four*
ESCs through its mixer, and ``fcs/throttle-cmd-norm[1..3]`` are read by nothing (checked with jsbsim 1.3.3:
setting only [1] leaves every motor at zero). Its onboard rate PIDs are disengaged (``fcs/ScasEngage`` = 0,
angle loop commented out). Individual motors are therefore driven through the per-ESC external inputs
``fcs/cmd{FR,AL,FL,AR}_ext_nd`` with ``throttle-cmd-norm[0]`` held at 0; motor order = front-right,
aft-left, front-left, aft-right (the F450 engine order).

Optional rotor drag. Real rotors produce a drag roughly linear in airspeed ("rotor drag", blade flapping and
induced drag); the F450 file only has a quadratic body drag (CD 1 on 0.016 m^2, 0.07 m/s^2 at 3 m/s). With
``rotor_drag`` > 0 the backend loads a copy of the F450 whose Aero.xml adds ``m * c * V`` along the relative
wind (written to a temporary directory; engine/systems come from the wheel). Units inside: SI, NED.
"""

from __future__ import annotations

import contextlib
import ctypes
import math
import os
import shutil
import sys
import tempfile
from dataclasses import dataclass
from typing import Iterator

import jsbsim
import numpy as np

FT = 0.3048  # m per ft
LBF = 4.4482216152605  # N per lbf
LBFT = LBF * FT  # N m per lbf ft
SLUG = 14.59390293720636  # kg per slug
G0 = 9.80665  # m/s^2
#: JSBSim property scaling the added rotor drag (a payload, a damaged propeller: the airframe's response changes).
DRAG_SCALE = "aero/rotor-drag-scale"
MOTORS = ("FR", "AL", "FL", "AR")
#: Motor positions (forward, right) in metres in the body frame, in MOTORS order (Propulsion.xml, x is aft there).
MOTOR_XY = np.array([[0.1651, 0.1651], [-0.1651, -0.1651], [0.1651, -0.1651], [-0.1651, 0.1651]])


@contextlib.contextmanager
def silenced_fds() -> Iterator[None]:
    """Silence stdout/stderr at fd and Python level (JSBSim prints a banner, config-version and "Failed to tie")."""
    saved = [os.dup(1), os.dup(2)]
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        # The jsbsim module routes its C++ output through Python's sys.stdout, so swap those too.
        with open(os.devnull, "w") as sink, contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
            yield
    finally:
        # JSBSim writes through C stdio; when stdout is a pipe it is block-buffered, so flush it while it
        # still points at /dev/null, or the warnings come out later on the real stdout.
        with contextlib.suppress(Exception):
            ctypes.CDLL(None).fflush(None)
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, devnull):
            os.close(fd)


@dataclass(frozen=True)
class Airframe:
    """What the controller needs to know about the airframe; measured from the loaded model, not assumed.

    Attributes:
        mass: kg.
        inertia: (3,) principal moments Ixx, Iyy, Izz in kg m^2.
        arm: m, |x| = |y| of each motor from the centre of gravity.
        thrust_max: N, static thrust of one motor at full command.
        thrust_table: (n, 2) static (command 0..1, thrust N of one motor), increasing.
        yaw_per_thrust: N m of reaction yaw moment per N of thrust on a motor of positive sense.
    """

    mass: float
    inertia: np.ndarray
    arm: float
    thrust_max: float
    thrust_table: np.ndarray
    yaw_per_thrust: float

    @property
    def hover_fraction(self) -> float:
        """Thrust-linearised collective (fraction of 4 * thrust_max) that balances gravity."""
        return self.mass * G0 / (4.0 * self.thrust_max)

    def command_for_thrust(self, thrust: np.ndarray) -> np.ndarray:
        """Invert the static curve: per-motor thrust (N) -> ESC command 0..1 (like ArduPilot's MOT_THST_EXPO)."""
        return np.interp(thrust, self.thrust_table[:, 1], self.thrust_table[:, 0])


class F450Backend:
    """One JSBSim FDM of the F450 at a fixed physics step; NED position relative to the reset point.

    Args:
        dt: physics step in seconds (2 or 2.5 ms both give the same hover and flights; the vehicle uses 2.5 ms).
        rotor_drag: linear drag coefficient c in 1/s (0 = the stock aircraft files).
        origin_alt: metres above ground of NED z = 0 (the ground is far below so the flights never touch it).
    """

    def __init__(self, dt: float = 0.0025, rotor_drag: float = 0.0, origin_alt: float = 100.0) -> None:
        self.dt = dt
        self.rotor_drag = rotor_drag
        self.origin_alt = origin_alt
        root = jsbsim.get_default_root_dir()
        with silenced_fds():
            self.fdm = jsbsim.FGFDMExec(root)
            self.fdm.set_debug_level(0)
            if rotor_drag > 0.0:
                self._load_with_rotor_drag(root, rotor_drag)
            else:
                self.fdm.load_model("F450")
            self.fdm.set_dt(dt)
            self._set_ic(np.zeros(3), np.zeros(3))
            self.fdm.run_ic()
        f = self.fdm
        self.fdm["fcs/throttle-cmd-norm[0]"] = 0.0
        self.lat0 = f["ic/lat-geod-rad"]
        self.lon0 = f["ic/long-gc-rad"]
        # Local flat-earth radii at the origin: the flights span metres, so the error is < 1 mm.
        a, e2 = 6378137.0, 6.69437999014e-3
        s = math.sin(self.lat0)
        self.r_north = a * (1 - e2) / (1 - e2 * s * s) ** 1.5
        self.r_east = a / math.sqrt(1 - e2 * s * s) * math.cos(self.lat0)
        self.h0 = f["position/h-sl-ft"] * FT
        self.airframe = self._calibrate()
        self.reset()

    def _load_with_rotor_drag(self, root: str, c: float) -> None:
        """Copy aircraft/F450 to a temp dir and add a DRAG term m*c*V (lbf) to its Aero.xml."""
        tmp = tempfile.mkdtemp(prefix="ksbo_f450_")
        src = os.path.join(root, "aircraft", "F450")
        dst = os.path.join(tmp, "F450")
        shutil.copytree(src, dst)
        aero_path = os.path.join(dst, "Aero.xml")
        with open(aero_path) as fh:
            aero = fh.read()
        # mass 1.4 kg is read back below; the coefficient is lbf per fps: m c V [N] = m c * FT * V[fps] / LBF.
        k = 1.4 * c * FT / LBF
        rotor = (f'<function name="aero/force/DRAG_rotor"><description>linear rotor drag m c V</description>'
                 f'<product><property>velocities/vt-fps</property><property>{DRAG_SCALE}</property>'
                 f'<value>{k:.8f}</value></product></function>')
        marker = '<axis name="DRAG">'
        if marker not in aero or "<aerodynamics>" not in aero:
            raise RuntimeError("unexpected F450 Aero.xml layout: no aerodynamics/DRAG axis")
        aero = aero.replace(marker, marker + "\n" + rotor, 1)
        aero = aero.replace("<aerodynamics>", f'<aerodynamics>\n<property value="1.0">{DRAG_SCALE}</property>', 1)
        with open(aero_path, "w") as fh:
            fh.write(aero)
        try:
            self.fdm.load_model_with_paths(
                "F450", tmp, os.path.join(root, "engine"), os.path.join(root, "systems")
            )
        finally:
            # JSBSim has parsed everything (resets do not re-read files), so nothing is left behind.
            shutil.rmtree(tmp, ignore_errors=True)

    def _set_ic(self, pos: np.ndarray, vel: np.ndarray) -> None:
        f = self.fdm
        f["ic/h-agl-ft"] = (self.origin_alt - pos[2]) / FT
        if hasattr(self, "lat0"):
            f["ic/lat-geod-rad"] = self.lat0 + pos[0] / self.r_north
            f["ic/long-gc-rad"] = self.lon0 + pos[1] / self.r_east
        f["ic/psi-true-deg"] = 0.0
        f["ic/theta-deg"] = 0.0
        f["ic/phi-deg"] = 0.0
        f["ic/vn-fps"] = vel[0] / FT
        f["ic/ve-fps"] = vel[1] / FT
        f["ic/vd-fps"] = vel[2] / FT
        f["ic/p-rad_sec"] = 0.0
        f["ic/q-rad_sec"] = 0.0
        f["ic/r-rad_sec"] = 0.0

    def _calibrate(self) -> Airframe:
        """Measure the static thrust curve and yaw reaction with the airframe held down (forces/hold-down)."""
        f = self.fdm
        mass = f["inertia/mass-slugs"] * SLUG
        inertia = np.array([f["inertia/ixx-slugs_ft2"], f["inertia/iyy-slugs_ft2"], f["inertia/izz-slugs_ft2"]])
        inertia = inertia * SLUG * FT * FT
        settle = int(round(2.0 / self.dt))  # motors reach steady rpm well within 2 s (time constant ~60 ms)
        table = []
        f["forces/hold-down"] = 1
        for u in np.linspace(0.0, 1.0, 21):
            f.reset_to_initial_conditions(0)
            self.set_motors(np.full(4, u))
            for _ in range(settle):
                f.run()
            table.append((u, -f["forces/fbz-prop-lbs"] * LBF / 4.0))
        # Yaw reaction: raise FR (sense +1) alone and read the yaw moment per N of extra thrust.
        f.reset_to_initial_conditions(0)
        self.set_motors(np.array([0.5, 0.4, 0.4, 0.4]))
        for _ in range(settle):
            f.run()
        total = -f["forces/fbz-prop-lbs"] * LBF
        t04 = float(np.interp(0.4, [r[0] for r in table], [r[1] for r in table]))
        yaw_per_thrust = f["moments/n-prop-lbsft"] * LBFT / max(total - 4 * t04, 1e-9)
        f["forces/hold-down"] = 0
        tab = np.array(table)
        return Airframe(mass=mass, inertia=inertia, arm=0.1651, thrust_max=float(tab[-1, 1]),
                        thrust_table=tab, yaw_per_thrust=float(yaw_per_thrust))

    def set_motors(self, cmd: np.ndarray) -> None:
        """ESC commands (4,) in 0..1, MOTORS order."""
        f = self.fdm
        f["fcs/cmdFR_ext_nd"] = float(cmd[0])
        f["fcs/cmdAL_ext_nd"] = float(cmd[1])
        f["fcs/cmdFL_ext_nd"] = float(cmd[2])
        f["fcs/cmdAR_ext_nd"] = float(cmd[3])

    def reset(self, pos: np.ndarray | None = None, vel: np.ndarray | None = None) -> None:
        """Back to level flight at ``pos`` (NED m) with ``vel`` (NED m/s), motors at hover, no reload."""
        pos = np.zeros(3) if pos is None else np.asarray(pos, dtype=float)
        vel = np.zeros(3) if vel is None else np.asarray(vel, dtype=float)
        self._set_ic(pos, vel)
        self.fdm.reset_to_initial_conditions(0)
        # Spin the props up to hover while held, so a flight starts trimmed rather than free-falling; then
        # run_ic() re-places the airframe (pos/vel/attitude) but keeps the engine and propeller states.
        hover = float(self.airframe.command_for_thrust(self.airframe.mass * G0 / 4.0))
        self.fdm["forces/hold-down"] = 1
        self.set_motors(np.full(4, hover))
        for _ in range(int(round(1.0 / self.dt))):
            self.fdm.run()
        self.fdm["forces/hold-down"] = 0
        self.fdm.run_ic()
        self._t_offset = self.fdm["simulation/sim-time-sec"]

    def run(self, n: int = 1) -> None:
        """Advance n physics steps with the current motor commands."""
        run = self.fdm.run
        for _ in range(n):
            run()

    @property
    def time_s(self) -> float:
        """Seconds since the last reset (the hold-down spin-up is not counted)."""
        return self.fdm["simulation/sim-time-sec"] - self._t_offset

    def read(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(pos NED m, vel NED m/s, roll/pitch/yaw rad, body rates p/q/r rad/s), each (3,)."""
        f = self.fdm
        pos = np.array([(f["position/lat-geod-rad"] - self.lat0) * self.r_north,
                        (f["position/long-gc-rad"] - self.lon0) * self.r_east,
                        self.h0 - f["position/h-sl-ft"] * FT])
        vel = np.array([f["velocities/v-north-fps"], f["velocities/v-east-fps"], f["velocities/v-down-fps"]]) * FT
        psi = (f["attitude/psi-rad"] + math.pi) % (2.0 * math.pi) - math.pi  # JSBSim gives 0..2 pi
        rpy = np.array([f["attitude/phi-rad"], f["attitude/theta-rad"], psi])
        rates = np.array([f["velocities/p-rad_sec"], f["velocities/q-rad_sec"], f["velocities/r-rad_sec"]])
        return pos, vel, rpy, rates

    def read_fast(self) -> list[float]:
        """The same 12 values as :meth:`read` as a flat list of floats (the per-physics-step hot path).

        Order: north, east, down, vn, ve, vd, roll, pitch, yaw, p, q, r (SI, NED).
        """
        f = self.fdm
        psi = f["attitude/psi-rad"]
        if psi > math.pi:
            psi -= 2.0 * math.pi
        return [(f["position/lat-geod-rad"] - self.lat0) * self.r_north,
                (f["position/long-gc-rad"] - self.lon0) * self.r_east,
                self.h0 - f["position/h-sl-ft"] * FT,
                f["velocities/v-north-fps"] * FT, f["velocities/v-east-fps"] * FT, f["velocities/v-down-fps"] * FT,
                f["attitude/phi-rad"], f["attitude/theta-rad"], psi,
                f["velocities/p-rad_sec"], f["velocities/q-rad_sec"], f["velocities/r-rad_sec"]]

    def hold(self, on: bool) -> None:
        """Clamp the airframe in place (used while the vehicle sits on the ground)."""
        self.fdm["forces/hold-down"] = 1 if on else 0

    def set_drag_scale(self, k: float) -> None:
        """The rotor drag times ``k`` (1 = as calibrated; only with ``rotor_drag`` > 0)."""
        if self.rotor_drag > 0.0:
            self.fdm[DRAG_SCALE] = k

    def set_wind_north(self, mps: float) -> None:
        """Wind toward north [m/s] (JSBSim's NED wind is the direction the air moves to)."""
        self.fdm["atmosphere/wind-north-fps"] = mps / FT

    def total_thrust(self) -> float:
        """Sum of the motor thrusts in N (fast path, no array)."""
        f = self.fdm
        return (f["propulsion/engine[0]/thrust-lbs"] + f["propulsion/engine[1]/thrust-lbs"]
                + f["propulsion/engine[2]/thrust-lbs"] + f["propulsion/engine[3]/thrust-lbs"]) * LBF

    def motor_thrust(self) -> np.ndarray:
        """(4,) current thrust of each motor in N."""
        return np.array([self.fdm[f"propulsion/engine[{i}]/thrust-lbs"] for i in range(4)]) * LBF
