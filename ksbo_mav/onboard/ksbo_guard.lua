-- ksbo_guard.lua: ksbo-mav's onboard guard for tuning trials on ArduCopter.
--
-- The tuner flies trial gains from the ground; if its link dies mid-trial, nothing on the ground can put the
-- baseline back. This script keeps that promise on the vehicle. While a trial is armed (KSG_STATE = 1, written
-- by the tuner) it checks, ten times a second:
--   * the tuner's heartbeat (gcs:last_seen(): heartbeats from the system id in MAV_GCS_SYSID / SYSID_MYGCS),
--   * the profile's box (north, east, height above the EKF origin) and tilt,
--   * the flight mode (GUIDED, or one the tuner declared its own for this flight: KSG_MODES) and that the
--     vehicle is still armed.
-- On a breach it writes the baseline gains back (saved, so a reboot keeps them), switches to BRAKE and, after
-- BRAKE_HOLD_MS, to SAFE_MODE (the pilot's own mode change is never overridden: gains only), sets
-- KSG_STATE = 2 and KSG_TRIP to the reason, and says so in a STATUSTEXT.
--
-- Protocol (docs: ksbo_mav/mav/onboard_guard.py):
--   KSG_STATE  0 idle, 1 trial armed (tuner writes 1 / 0), 2 tripped, 3 arming refused (guard writes)
--   KSG_TRIP   why: 0 none, 1 link lost, 2 box, 3 tilt, 4 pilot mode change, 5 disarmed, 6 no position,
--              7 tracking error (figure-8 on board)
--   KSG_F8     the tuner writes 1 (trial armed) to start the figure-8 on board, 0 to stop it
--   KSG_T0     the vehicle time (ms, modulo 2^24) of the figure-8's t = 0, once it started; -1 before
--   KSG_MODES  the custom modes (bit m = mode m, m < 24) the tuner flies in besides GUIDED during the next armed
--              flight (a validation flight's LOITER or AUTO), written before KSG_STATE = 1; read when it arms,
--              put back to 0 when the armed flight ends
--   NAMED_VALUE_FLOAT KSG_ALIVE = state, KSG_CFG = CONFIG_ID, twice a second.
--
-- The tuner renders the block between the CONFIG markers (the gain names with their baseline values, the
-- limits, the modes) before it uploads the script. As shipped the list of gains is empty and the guard refuses
-- to arm: an unrendered copy can do nothing.
--
-- The figure-8 on board (F8_DURATION_MS > 0): while a trial is armed and KSG_F8 is 1, the script flies the
-- campaign's figure-8 itself (ksbo_task.figure8_ne with its lead-in, the same formulas), setting a position +
-- velocity + acceleration target every F8_TICK_MS; the position controller dead-reckons it at the loop rate in
-- between. At the end it holds the end point with a position-only target. Every check above stays on, plus the
-- tracking error against the reference it flies (TRACK_MAX). The tuner only starts it and scores the telemetry.

-- KSBO_CONFIG_BEGIN
local CONFIG_ID = 0
local GAINS = {}
local LINK_TIMEOUT_MS = 3000
local X_MAX, Y_MAX, Z_MIN, Z_MAX = 0, 0, 0, 0
local TILT_MAX_DEG = 0
local BRAKE_ACCEL = 0
local GUIDED_MODE, BRAKE_MODE, SAFE_MODE, LAND_MODE = 4, 17, 5, 9
local BRAKE_HOLD_MS = 2000
local F8_AMP_N, F8_AMP_E, F8_PERIOD, F8_UP, F8_LEAD = 0, 0, 0, 0, 0
local F8_DURATION_MS, F8_TICK_MS, TRACK_MAX = 0, 10, 0
-- KSBO_CONFIG_END

local PARAM_TABLE_KEY = 87
local IDLE, ARMED, TRIPPED, REFUSED = 0, 1, 2, 3
local LINK, BOX, TILT, PILOT, DISARMED, NO_POSITION, TRACK = 1, 2, 3, 4, 5, 6, 7
local TICK_MS, ALIVE_MS = 100, 500

-- ArduPilot cannot grow a table after it was added: a vehicle that ran a guard with fewer parameters since its boot
-- must be rebooted once. Said in a KSG text, which the tuner's installer shows.
if not param:add_table(PARAM_TABLE_KEY, "KSG_", 5) then
  gcs:send_text(0, "KSG: no KSG_ table (older guard?): reboot vehicle")
  return
end
assert(param:add_param(PARAM_TABLE_KEY, 1, "STATE", 0), "ksbo guard: could not add KSG_STATE")
assert(param:add_param(PARAM_TABLE_KEY, 2, "TRIP", 0), "ksbo guard: could not add KSG_TRIP")
assert(param:add_param(PARAM_TABLE_KEY, 3, "F8", 0), "ksbo guard: could not add KSG_F8")
assert(param:add_param(PARAM_TABLE_KEY, 4, "T0", -1), "ksbo guard: could not add KSG_T0")
assert(param:add_param(PARAM_TABLE_KEY, 5, "MODES", 0), "ksbo guard: could not add KSG_MODES")
-- A reboot or a script restart never starts armed (the tuner's PARAM_SET saved KSG_STATE).
param:set("KSG_STATE", IDLE)
param:set("KSG_F8", 0)
param:set("KSG_T0", -1)
param:set("KSG_MODES", 0)

local state = IDLE
local own_modes = 0 -- KSG_MODES as read when the flight armed
local brake_since = nil
local last_alive = 0
local f8_start = nil -- millis() of the figure-8's t = 0 while it flies (or holds its end point)
local f8_done = false
local f8_ticks = 0
local f8_pos, f8_vel, f8_acc = Vector3f(), Vector3f(), Vector3f()

local function now_ms()
  return millis():tofloat()
end

local function send_alive()
  gcs:send_named_float("KSG_ALIVE", state)
  gcs:send_named_float("KSG_CFG", CONFIG_ID)
  last_alive = now_ms()
end

local function set_state(s, reason)
  if s ~= ARMED then
    f8_start = nil -- a trip or the tuner's end of the trial ends the figure-8 (a trip also took control)
    param:set("KSG_F8", 0)
    param:set("KSG_T0", -1)
    param:set("KSG_MODES", 0) -- the next flight is GUIDED only unless the tuner says otherwise again
    own_modes = 0
  end
  state = s
  param:set("KSG_STATE", s)
  if reason then
    param:set("KSG_TRIP", reason)
  end
  send_alive()
end

local function restore_gains()
  local failed = 0
  for _, g in ipairs(GAINS) do
    if not param:set_and_save(g[1], g[2]) then
      failed = failed + 1
    end
  end
  return failed
end

-- Stop the vehicle where it is: BRAKE, else the safe mode, else LAND.
local function stop_vehicle()
  if vehicle:set_mode(BRAKE_MODE) then
    brake_since = now_ms()
    return "BRAKE"
  end
  if vehicle:set_mode(SAFE_MODE) then
    return "mode " .. SAFE_MODE
  end
  if vehicle:set_mode(LAND_MODE) then
    return "LAND"
  end
  return "NO mode change"
end

-- A STATUSTEXT carries 50 characters: the texts are kept short enough for "KSG: <why>; gains back; BRAKE".
local function trip(reason, text, take_control)
  local failed = restore_gains()
  local gains = failed == 0 and "gains back" or string.format("%d gains NOT back", failed)
  local action = take_control and ("; " .. stop_vehicle()) or ""
  set_state(TRIPPED, reason)
  gcs:send_text(failed == 0 and 2 or 1, string.format("KSG: %s; %s%s", text, gains, action))
end

-- Why a trial must not be armed now, or nil.
local function refusal()
  if #GAINS == 0 then
    return "no gains configured"
  end
  if not arming:is_armed() then
    return "vehicle disarmed"
  end
  if vehicle:get_mode() ~= GUIDED_MODE then
    return "not in GUIDED"
  end
  local seen = gcs:last_seen():tofloat()
  if seen == 0 or now_ms() - seen > LINK_TIMEOUT_MS then
    return "no heartbeat from MAV_GCS_SYSID"
  end
  return nil
end

-- get_roll_rad/get_pitch_rad replaced get_roll/get_pitch (which now warn once); older firmware has only those.
local HAS_RAD = pcall(function() return ahrs:get_roll_rad() end)
local function tilt_deg()
  local roll = HAS_RAD and ahrs:get_roll_rad() or ahrs:get_roll()
  local pitch = HAS_RAD and ahrs:get_pitch_rad() or ahrs:get_pitch()
  -- the body z axis against the vertical: max(|roll|, |pitch|) reads 35 where roll and pitch of 35 lean 47
  return math.deg(math.acos(math.max(-1, math.min(1, math.cos(roll) * math.cos(pitch)))))
end

local function outside_box()
  local p = ahrs:get_relative_position_NED_origin()
  if not p then
    return NO_POSITION, "no position estimate"
  end
  local north, east, up = p:x(), p:y(), -p:z()
  if BRAKE_ACCEL > 0 then
    local v = ahrs:get_velocity_NED()
    if v then
      local k = 1 / (2 * BRAKE_ACCEL)
      north = north + v:x() * math.abs(v:x()) * k
      east = east + v:y() * math.abs(v:y()) * k
      up = up - v:z() * math.abs(v:z()) * k
    end
  end
  if math.abs(north) > X_MAX then
    return BOX, string.format("|north| %.1f>%.1f m", math.abs(north), X_MAX)
  end
  if math.abs(east) > Y_MAX then
    return BOX, string.format("|east| %.1f>%.1f m", math.abs(east), Y_MAX)
  end
  if up < Z_MIN or up > Z_MAX then
    return BOX, string.format("up %.1f m out of %.0f..%.0f", up, Z_MIN, Z_MAX)
  end
  local tilt = tilt_deg()
  if tilt > TILT_MAX_DEG then
    return TILT, string.format("tilt %.0f>%.0f deg", tilt, TILT_MAX_DEG)
  end
  return nil
end

-- GUIDED, or a mode the tuner declared its own for this flight (bit m of own_modes).
local function tuners_mode(mode)
  return mode == GUIDED_MODE or (mode >= 0 and mode < 24 and math.floor(own_modes / 2 ^ mode) % 2 == 1)
end

local function watch()
  if not arming:is_armed() then
    trip(DISARMED, "disarmed", false)
    return
  end
  if not tuners_mode(vehicle:get_mode()) then
    trip(PILOT, "pilot mode change", false)
    return
  end
  local seen = gcs:last_seen():tofloat()
  local silent = now_ms() - seen
  if silent > LINK_TIMEOUT_MS then
    trip(LINK, string.format("link lost %.1f s", silent / 1000), true)
    return
  end
  local reason, text = outside_box()
  if reason then
    trip(reason, text, true)
  end
end

-- ksbo_task.lead_in: phase, its rate and the rate's derivative at t (s); the pattern starts from rest.
local function lead_in(t)
  if F8_LEAD <= 0 then
    return t, 1, 0
  end
  t = math.max(t, 0)
  if t >= F8_LEAD then
    return t - 0.5 * F8_LEAD, 1, 0
  end
  local u = t / F8_LEAD
  return F8_LEAD * (u * u * u - 0.5 * u * u * u * u), u * u * (3 - 2 * u), 6 * u * (1 - u) / F8_LEAD
end

-- ksbo_task.figure8_ne.Figure8H: the order-th time derivative (0, 1, 2) of (north, east) at phase ph.
local function pattern(ph, order)
  local w = 2 * math.pi / F8_PERIOD
  local k = order * math.pi / 2
  return F8_AMP_N * w ^ order * math.sin(w * ph + k), F8_AMP_E * (2 * w) ^ order * math.sin(2 * w * ph + k)
end

-- The reference t seconds after the figure-8's start into f8_pos, f8_vel, f8_acc (NED, m from the EKF origin).
local function reference(t)
  local ph, r, rd = lead_in(t)
  local n0, e0 = pattern(ph, 0)
  local n1, e1 = pattern(ph, 1)
  local n2, e2 = pattern(ph, 2)
  f8_pos:x(n0); f8_pos:y(e0); f8_pos:z(-F8_UP)
  f8_vel:x(n1 * r); f8_vel:y(e1 * r); f8_vel:z(0)
  f8_acc:x(n2 * r * r + n1 * rd); f8_acc:y(e2 * r * r + e1 * rd); f8_acc:z(0)
end

-- Hold a position with a position-only target (never times out), yaw rate 0 as the tuner's holds.
local function hold(pos)
  vehicle:set_target_pos_NED(pos, false, 0, true, 0, false, false)
end

-- One tick of the figure-8 of an armed trial: start it when the tuner asks, fly it, hold its end point.
local function fly_figure8()
  if F8_DURATION_MS <= 0 then
    return
  end
  local wanted = param:get("KSG_F8")
  if not f8_start then
    if wanted == 1 then
      f8_start, f8_done, f8_ticks = millis(), false, 0
      param:set("KSG_T0", (f8_start & 0xFFFFFF):tofloat())
      gcs:send_text(6, "KSG: figure-8 started")
    end
    return
  end
  if wanted ~= 1 then -- the tuner stopped it (its monitor tripped): stop where the vehicle is
    f8_start = nil
    param:set("KSG_T0", -1)
    local p = ahrs:get_relative_position_NED_origin()
    if p then
      hold(p)
    end
    gcs:send_text(6, "KSG: figure-8 stopped by the tuner")
    return
  end
  if f8_done then
    return
  end
  local t_ms = (millis() - f8_start):tofloat()
  reference(math.min(t_ms, F8_DURATION_MS) * 0.001)
  if t_ms >= F8_DURATION_MS then
    hold(f8_pos)
    f8_done = true
    gcs:send_text(6, string.format("KSG: figure-8 done, %d targets", f8_ticks))
    return
  end
  vehicle:set_target_posvelaccel_NED(f8_pos, f8_vel, f8_acc, false, 0, true, 0, false)
  f8_ticks = f8_ticks + 1
  local p = ahrs:get_relative_position_NED_origin()
  if TRACK_MAX > 0 and p then
    local err = (p - f8_pos):length()
    if err > TRACK_MAX then
      trip(TRACK, string.format("tracking error %.1f>%.1f m", err, TRACK_MAX), true)
    end
  end
end

local function update()
  local wanted = param:get("KSG_STATE")
  if state == ARMED then
    if wanted == IDLE then
      if f8_start and not f8_done then -- ended mid figure-8: hold where the vehicle is
        local p = ahrs:get_relative_position_NED_origin()
        if p then
          hold(p)
        end
      end
      set_state(IDLE)
    else
      watch()
      if state == ARMED then
        fly_figure8()
      end
    end
  elseif wanted == ARMED and state ~= ARMED then
    local why = refusal()
    if why then
      set_state(REFUSED)
      gcs:send_text(4, "KSG: trial not armed: " .. why)
    else
      local modes = param:get("KSG_MODES") or 0
      set_state(ARMED, 0)
      own_modes = modes
      gcs:send_text(6, modes > 0 and string.format("KSG: trial armed, modes %d", math.floor(modes))
                    or "KSG: trial armed")
    end
  elseif wanted == IDLE and state ~= IDLE then
    set_state(IDLE)
  end
  if brake_since and now_ms() - brake_since > BRAKE_HOLD_MS then
    if vehicle:get_mode() == BRAKE_MODE then
      vehicle:set_mode(SAFE_MODE)
    end
    brake_since = nil
  end
  if now_ms() - last_alive >= ALIVE_MS then
    send_alive()
  end
end

-- An error must not silently end the guard: report it and keep running.
local function protected()
  local ok, err = pcall(update)
  if not ok then
    gcs:send_text(0, "KSG: error: " .. tostring(err))
  end
  -- Faster while the figure-8 flies: each tick sets the next target.
  return protected, (f8_start and not f8_done) and F8_TICK_MS or TICK_MS
end

gcs:send_text(6, string.format("KSG: guard running, config %d, %d gains", CONFIG_ID, #GAINS))
return protected, TICK_MS
