"""Built-in MAVLink 2 vehicle simulator (``ksbo-mav sim``, ``python -m ksbo_sim.mavlink``): a
:class:`~ksbo_sim.vehicle.VehicleModel` served like an autopilot's SITL.

Running it::

    ksbo-mav sim --udp 127.0.0.1:14560 --lockstep        # prints "ksbo-sim ready udp:127.0.0.1:14560 ..."
    ksbo-mav sim --tcp 127.0.0.1:5760 --speedup 10 --params vehicle.param --noise 0.01
    ksbo-mav sim --udp 127.0.0.1:0 --out 127.0.0.1:14550  # port 0 = any free port; also send to a listening GCS

UDP answers every address that talked to it in the last minute (plus ``--out`` addresses); ``--instance N`` adds
10*N to the port. SIGINT/SIGTERM stop it cleanly (exit 0). Identity (personality ``ours``): sysid 1, compid 1,
HEARTBEAT type 2 (quadrotor), autopilot 0 (GENERIC), AUTOPILOT_VERSION vendor_id 0x4B53 ("KS"), product_id 1
planar / 2 copter3d, flight_custom_version "ksbosim", capabilities MAVLINK2 | PARAM_ENCODE_C_CAST |
SET_POSITION_TARGET_LOCAL_NED. Modes (ArduCopter numbers): 0 STABILIZE (boot; holds when airborne, no RC),
3 AUTO (the stored mission's waypoints as straight legs at WP_SPEED: ``auto_nav``), 4 GUIDED, 5 LOITER /
16 POSHOLD / 17 BRAKE (hold), 9 LAND.

The mission protocol (``mission_store``): upload, download, clear and set-current of the flight plan; home is item 0
for ArduPilot and ours, PX4 flies from item 0; home (the local origin, on the ground) is ArduPilot SITL's CMAC field,
answered as GPS_GLOBAL_ORIGIN and HOME_POSITION on REQUEST_MESSAGE. RC_CHANNELS on request: sticks centred.

Frames (planar vehicle): planar x = NED north, planar z = -NED down (ground at down 0, home at the origin),
east always 0, ATTITUDE.pitch = -theta. Telemetry: HEARTBEAT, SYS_STATUS, SYSTEM_TIME (1 Hz), ATTITUDE,
LOCAL_POSITION_NED, SERVO_OUTPUT_RAW, ACTUATOR_OUTPUT_STATUS (10 Hz; actuator[0:2] = pair thrusts in N, exact
float32 for the input term of P(a)); time_boot_ms / time_usec are simulated time. Rates via
SET_MESSAGE_INTERVAL or REQUEST_DATA_STREAM (ArduCopter groups).

Lockstep (``--lockstep``; details in ``server``): each SET_POSITION_TARGET_LOCAL_NED advances one control step
(20 ms) and is answered by that step's LOCAL_POSITION_NED (a re-sent one, same stamp, is answered again, not
stepped twice); MAV_CMD_USER_2 (31011, p1 = seconds) advances without setpoints and is ACKed at the end;
otherwise time stands still (idle HEARTBEAT each wall second).

Simulator-only commands (``commands``): 31010 set state (p1..p3 NED position, p4..p6 NED velocity; armed; zeroes
the controller: how a figure-8 episode starts at the origin with a chosen initial velocity), 31011 lockstep step,
31012 reset after a crash (also done by re-arming).

Parameters: the model's (planar: the 9 gains of ``params/sim-planar.toml``, FENCE_X_MAX, FENCE_Z_MIN,
FENCE_Z_MAX, FENCE_TILT_DEG) then the endpoint's (``server.endpoint_specs``): SIM_PKT_LOSS_IN/OUT,
SIM_DELAY_MS, SIM_MUTE_S, SIM_PILOT_MODE, SIM_PSET_FAIL, SIM_FAULT_AFTER (fault switches, volatile), SIM_SP_TIMEOUT,
SIM_POS_NOISE, SIM_VEL_NOISE, SIM_ACC_NOISE, TKOFF_SPEED, LAND_SPEED, WP_SPEED, WP_ACCEL, WP_RADIUS (AUTO),
SIM_LOCKSTEP (read-only), then the simulated
guard's (``guard.params``): SCR_ENABLE, MAV_GCS_SYSID (or SYSID_MYGCS), KSG_STATE, KSG_TRIP.

Modules, one per MAVLink service: ``link`` (sockets, fault injection), ``params`` (parameter protocol,
persistence), ``commands`` (COMMAND_LONG/ACK, modes), ``ftp`` (MAVLink FTP: scripts written, listed and removed;
reads refused), ``guard`` (the onboard guard simulated: SCR_ENABLE, MAV_GCS_SYSID, KSG_STATE/KSG_TRIP,
MAV_CMD_SCRIPTING), ``telemetry`` (streams), ``flight`` (arming, takeoff, guided setpoints, hold, land, crash,
estimator), ``mission_store`` (the mission protocol), ``auto_nav`` (AUTO's legs), ``server`` (clock, lockstep,
dispatch, SIM_* faults), ``personality`` (autopilot identities), ``vehicles`` (model registry), ``options``
(command line).
"""

from ksbo_sim.mavlink.personality import OURS, PERSONALITIES, Mode, Personality

__all__ = ["OURS", "PERSONALITIES", "Mode", "Personality"]
