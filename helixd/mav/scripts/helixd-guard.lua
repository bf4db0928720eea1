--[[
helixd-guard.lua — a dead-man switch for helixd's scroll outputs, run by ArduPilot Rover.
Version 1 (HXG_VERSION = 1).

What it does
  helixd (the companion daemon) is the "GCS" of the autopilot: it sends HEARTBEATs as system id
  MAV_GCS_SYSID. ArduPilot records the time of the last HEARTBEAT (also RC_CHANNELS_OVERRIDE and
  MANUAL_CONTROL) from that system id; scripting reads it as gcs:last_seen().
  Every 50 ms this script checks: vehicle armed AND helixd silent for longer than HXG_TIMEOUT
  (or never heard from since boot) -> GUARD:
    * every guarded output (HXG_CHAN1..4) is driven to its SERVOn_TRIM with
      SRV_Channels:set_output_pwm_chan_timeout(n-1, trim, 100 ms), renewed every 50 ms while
      the silence lasts. For an RC-passthrough output (SERVOn_FUNCTION 1, 51..66, 140..155)
      ArduPilot copies the RC input to the output after the servo override is applied, so the
      script also overrides that RC input channel (rc:get_channel(c):set_override) with the
      trim (RCc_TRIM for the "mapped" functions 140..155), renewed the same way;
    * asks for HOLD (Rover mode 4) once per guard episode, unless already in HOLD;
    * says so once: STATUSTEXT CRITICAL "helixd-guard: no heartbeat <T> ms, trim + HOLD"
      (or "helixd-guard: no heartbeat yet, trim + HOLD" when helixd was never heard since
      boot); "helixd-guard: HOLD refused" (WARNING) if the mode change fails.
  When the heartbeat returns (or the vehicle is disarmed, or HXG_ENABLE is set to 0) it lets
  go: it stops renewing, says so once (NOTICE "helixd-guard: heartbeat back, released",
  "helixd-guard: disarmed, released" or "helixd-guard: disabled, released").

Pilot takeover: leaving HOLD hands the scrolls to the pilot
  While it guards, the script remembers the mode it expects, base_mode: HOLD once HOLD was
  granted or seen, else the mode it found at engagement. Each update (50 ms) it reads
  vehicle:get_mode() (the mode number): HOLD -> base_mode = HOLD; another mode that differs
  from base_mode -> a human (the pilot's mode switch, a ground station) has taken over: it
  lets go at once (no more renewals; it clears its own RC overrides of the passthrough inputs
  with set_override(0), so the radio drives a passthrough output now, not after
  RC_OVERRIDE_TIME) and says once NOTICE "helixd-guard: mode <n>, pilot in charge, released"
  (n = Rover mode number, 0 = MANUAL). It then stays released, whatever the mode and however
  long helixd is silent, until helixd is heard again (gcs:last_seen() newer than the release),
  the vehicle is disarmed or HXG_ENABLE goes to 0; after that it watches as before (a later
  silence of helixd engages it again). So after helixd's fallback (helixd asked HOLD, released
  its overrides and exited), the pilot flips the mode switch out of HOLD to drive by radio.
  Edge cases:
    * already HOLD at engagement (helixd's own fallback, a pilot takeover to HOLD): no request,
      base_mode = HOLD; any later non-HOLD mode releases.
    * HOLD asked and granted (vehicle:set_mode true; Rover switches at once): base_mode = HOLD.
    * HOLD refused (e.g. the mode cannot be left, "HOLD refused" sent): base_mode = the mode
      found at engagement, and staying in it is no takeover: the outputs stay at trim. A later
      change to HOLD makes base_mode HOLD; a change to any other mode releases.
    * rapid switch: the script samples the mode every 50 ms. A pilot who goes to HOLD and out
      again between two samples is still seen (the mode differs from base_mode = HOLD). Only a
      round trip back to exactly base_mode within 50 ms goes unseen; flip again.
    * a mode change made before the guard engages (within HXG_TIMEOUT of helixd's last
      message) is undone by its HOLD request: that is no takeover of the guard's HOLD; flip
      the switch out of HOLD again after the "trim + HOLD" message.
    * a failsafe that changes the mode while the guard holds (e.g. FS_ACTION RTL after a
      refused HOLD; the GCS failsafe does not act in HOLD) also counts as leaving base_mode
      and releases: the autopilot's failsafe mode is in charge then.
  After a takeover release a function-0 output (servo backend) keeps the trim value
  (ArduPilot leaves the last override value on the output when its timeout runs out; nothing
  else writes it until a DO_SET_SERVO); an RC-passthrough output follows the pilot's RC input.
  After letting go, a function-0 output keeps the trim value until the next DO_SET_SERVO; a
  DO_SET_SERVO that arrives while the guard still holds (before it has seen the heartbeat and
  its last 100 ms renewal has run out, about 0.2 s) is ACKed ACCEPTED but has no effect, so
  re-send after "heartbeat back". An RC-passthrough output keeps the trim RC override until
  helixd's next RC_CHANNELS_OVERRIDE replaces it or RC_OVERRIDE_TIME expires. While the guard
  holds a passthrough output its RC override counts as RC input (radio failsafe) like any GCS
  override; and as the vehicle is then in HOLD, Rover's GCS failsafe does not fire (it skips
  HOLD) unless someone leaves HOLD.
  Disarmed, it does nothing: it never fights the pilot or helixd's own neutral on the bench.
  Armed but helixd never heard from since boot counts as silent: the scrolls are held at trim
  and HOLD asked; to drive by radio alone (no helixd) switch out of HOLD (see above), or set
  HXG_ENABLE 0.

  Times: ArduPilot's millis(), whole milliseconds. Silent means now - last_seen > timeout.
  helixd must refresh last_seen faster than HXG_TIMEOUT: with the servo (DO_SET_SERVO) backend
  only its HEARTBEATs count, so link.heartbeat_rate_hz >= 4 for the default 0.5 s
  (its default 1 Hz would trip the guard between heartbeats); with the RC-override backend its
  20 Hz overrides count as well.

Parameters (own table, key 144, prefix HXG_)
  HXG_ENABLE   1      0 = off (lets go at once), anything > 0 = on
  HXG_TIMEOUT  0.5    s of silence before guarding; clamped to 0.1 .. 10 s. Keep it well under
                      FS_GCS_TIMEOUT (default 5 s)
  HXG_CHAN1    1      servo output numbers (1-based, SERVOn) guarded; 0 = none. Values outside
  HXG_CHAN2    2      1..16 are ignored, duplicates guarded once. The defaults are helixd's
  HXG_CHAN3    3      default actuation channels 1..4 (the SITL skid suite maps scrolls to
  HXG_CHAN4    4      3, 4, 1, 2: the same set)
  HXG_VERSION  1      set by the script at start (and re-asserted); helixd reads it to know
                      which guard runs. Not a setting.

Install (real autopilot)
  1. Set SCR_ENABLE 1 and reboot (the SCR_ parameters and scripting appear).
  2. Copy this file to the SD card as APM/scripts/helixd-guard.lua (MAVFTP works too).
  3. Reboot. "helixd-guard: v1 on, outputs 1 2 3 4, 500 ms" appears in the messages and the
     HXG_ parameters exist (refresh the parameter list).
  4. Check MAV_GCS_SYSID = helixd's link.source_system (247) and FS_GCS_ENABLE 1 stays as the
     slow backstop.
  SITL: put it in scripts/ of ardurover's working directory, SCR_ENABLE 1 in --defaults
  (then no reboot is needed). The HXG_ values themselves are NOT read from --defaults files
  (a script's parameters load from storage only): set them with PARAM_SET after boot.
--]]

local VERSION = 1
local PARAM_TABLE_KEY = 144 -- free in ArduPilot's applets/examples (master snapshot 531699d, 2026-04)
local PARAM_TABLE_PREFIX = "HXG_"
local PERIOD_MS = 50 -- update period
local OVERRIDE_MS = 100 -- each renewal holds the outputs this long (2 periods)
local MODE_HOLD = 4 -- Rover
local MAX_OUTPUT = 16
local TIMEOUT_MIN_MS = 100
local TIMEOUT_MAX_MS = 10000
local ERROR_TEXT_INTERVAL_MS = 5000

local MAV_SEVERITY = {EMERGENCY=0, ALERT=1, CRITICAL=2, ERROR=3, WARNING=4, NOTICE=5, INFO=6, DEBUG=7}

assert(param:add_table(PARAM_TABLE_KEY, PARAM_TABLE_PREFIX, 7), "helixd-guard: could not add param table")

local function bind_add_param(name, idx, default_value)
  assert(param:add_param(PARAM_TABLE_KEY, idx, name, default_value),
         string.format("helixd-guard: could not add param %s%s", PARAM_TABLE_PREFIX, name))
  return Parameter(PARAM_TABLE_PREFIX .. name)
end

local HXG_ENABLE = bind_add_param("ENABLE", 1, 1)
local HXG_TIMEOUT = bind_add_param("TIMEOUT", 2, 0.5)
local HXG_CHAN = {
  bind_add_param("CHAN1", 3, 1),
  bind_add_param("CHAN2", 4, 2),
  bind_add_param("CHAN3", 5, 3),
  bind_add_param("CHAN4", 6, 4),
}
local HXG_VERSION = bind_add_param("VERSION", 7, VERSION)
HXG_VERSION:set(VERSION)

-- the guarded outputs (1-based), in HXG_CHAN1..4 order, valid and unique
local function guarded_outputs()
  local outputs = {}
  local seen = {}
  for _, p in ipairs(HXG_CHAN) do
    local n = math.floor(p:get() + 0.5)
    if n >= 1 and n <= MAX_OUTPUT and not seen[n] then
      seen[n] = true
      outputs[#outputs + 1] = n
    end
  end
  return outputs
end

local function timeout_ms()
  local ms = math.floor(HXG_TIMEOUT:get() * 1000 + 0.5)
  if ms < TIMEOUT_MIN_MS then
    return TIMEOUT_MIN_MS
  end
  if ms > TIMEOUT_MAX_MS then
    return TIMEOUT_MAX_MS
  end
  return ms
end

-- RC input feeding a passthrough output (nil if the output is not a passthrough), and whether
-- the input's own trim (mapped passthrough) rather than the output's trim is the neutral value
local function passthrough_input(output, fn)
  if fn == 1 then
    return output, false -- k_manual: RC input n -> output n
  elseif fn >= 51 and fn <= 66 then
    return fn - 50, false -- k_rcin1..16
  elseif fn >= 140 and fn <= 155 then
    return fn - 139, true -- k_rcin1_mapped..16: output = trim when the input is at its trim
  end
  return nil, false
end

-- parameter handles by name, looked up once (nil when the parameter does not exist)
local handles = {}
local function param_value(name)
  local h = handles[name]
  if h == nil then
    h = Parameter()
    if not h:init(name) then
      h = false
    end
    handles[name] = h
  end
  if h then
    return h:get()
  end
  return nil
end

-- hold every guarded output at its SERVOn_TRIM for OVERRIDE_MS
local function hold_trim(outputs)
  for _, n in ipairs(outputs) do
    local trim = param_value(string.format("SERVO%d_TRIM", n))
    if trim then
      trim = math.floor(trim + 0.5)
      SRV_Channels:set_output_pwm_chan_timeout(n - 1, trim, OVERRIDE_MS) -- 0-based channel!
      local fn = param_value(string.format("SERVO%d_FUNCTION", n)) or 0
      local input, mapped = passthrough_input(n, math.floor(fn + 0.5))
      if input then
        local rc_value = trim
        if mapped then
          rc_value = math.floor((param_value(string.format("RC%d_TRIM", input)) or 1500) + 0.5)
        end
        local ch = rc:get_channel(input) -- 1-based
        if ch then
          ch:set_override(rc_value)
        end
      end
    end
  end
end

local guarding = false
local base_mode = nil -- while guarding: the mode the guard expects (HOLD once seen or granted)
local released_ms = nil -- millis() when a pilot took over (nil: not released by a takeover)
local last_error_ms = nil

-- let go of the RC overrides the guard put on passthrough inputs (override 0 clears one), so
-- that the pilot's radio drives a passthrough output at once, not after RC_OVERRIDE_TIME
local function release_rc(outputs)
  for _, n in ipairs(outputs) do
    local fn = param_value(string.format("SERVO%d_FUNCTION", n)) or 0
    local input = passthrough_input(n, math.floor(fn + 0.5))
    if input then
      local ch = rc:get_channel(input) -- 1-based
      if ch then
        ch:set_override(0)
      end
    end
  end
end

local function update()
  if HXG_VERSION:get() ~= VERSION then
    HXG_VERSION:set(VERSION)
  end
  local enabled = HXG_ENABLE:get() > 0
  local armed = arming:is_armed()
  local now_ms = millis()
  local seen_ms = gcs:last_seen() -- uint32_t userdata, 0 = never (compare with :toint())
  local never = seen_ms:toint() == 0
  local tmo = timeout_ms()
  local silent = never or (now_ms - seen_ms):toint() > tmo

  if not enabled then
    released_ms = nil
    if guarding then
      guarding = false
      gcs:send_text(MAV_SEVERITY.NOTICE, "helixd-guard: disabled, released")
    end
    return
  end

  if released_ms ~= nil then
    -- a pilot took over: hands off until disarm or until helixd is heard again
    if not armed or (not never and (seen_ms - released_ms):toint() > 0) then
      released_ms = nil
    else
      return
    end
  end

  if armed and silent then
    local mode = vehicle:get_mode()
    if not guarding then
      guarding = true
      base_mode = mode
      if never then
        gcs:send_text(MAV_SEVERITY.CRITICAL, "helixd-guard: no heartbeat yet, trim + HOLD")
      else
        gcs:send_text(MAV_SEVERITY.CRITICAL,
                      string.format("helixd-guard: no heartbeat %d ms, trim + HOLD", tmo))
      end
      if mode ~= MODE_HOLD then
        if vehicle:set_mode(MODE_HOLD) then
          base_mode = MODE_HOLD
        else
          gcs:send_text(MAV_SEVERITY.WARNING, "helixd-guard: HOLD refused")
        end
      end
    elseif mode == MODE_HOLD then
      base_mode = MODE_HOLD
    elseif mode ~= base_mode then
      -- a human (mode switch, ground station) left the mode the guard put or found: let go
      local outputs = guarded_outputs()
      guarding = false
      base_mode = nil
      released_ms = now_ms
      release_rc(outputs)
      gcs:send_text(MAV_SEVERITY.NOTICE,
                    string.format("helixd-guard: mode %d, pilot in charge, released", mode))
      return
    end
    hold_trim(guarded_outputs())
  elseif guarding then
    guarding = false
    base_mode = nil
    if not armed then
      gcs:send_text(MAV_SEVERITY.NOTICE, "helixd-guard: disarmed, released")
    else
      gcs:send_text(MAV_SEVERITY.NOTICE, "helixd-guard: heartbeat back, released")
    end
  end
end

local function protected_wrapper()
  local ok, err = pcall(update)
  if not ok then
    local now = millis():toint()
    if last_error_ms == nil or now - last_error_ms >= ERROR_TEXT_INTERVAL_MS then
      last_error_ms = now
      gcs:send_text(MAV_SEVERITY.EMERGENCY, "helixd-guard: internal error: " .. tostring(err))
    end
  end
  return protected_wrapper, PERIOD_MS
end

local function start_text()
  local outputs = guarded_outputs()
  local list = {}
  for i, n in ipairs(outputs) do
    list[i] = tostring(n)
  end
  if #list == 0 then
    list[1] = "none"
  end
  local state = HXG_ENABLE:get() > 0 and "on" or "off"
  return string.format("helixd-guard: v%d %s, outputs %s, %d ms", VERSION, state,
                       table.concat(list, " "), timeout_ms())
end

gcs:send_text(MAV_SEVERITY.INFO, start_text())

return protected_wrapper()
