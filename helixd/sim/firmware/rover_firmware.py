"""ArduPilot Rover behaviour model (pure: no sockets, no clocks; times are simulated seconds).

Boot: silent, then HEARTBEAT custom_mode 16 (INITIALISING) for ``boot_duration_s``, then
INITIAL_MODE (0 = MANUAL). Arming (GCS_Common.cpp handle_command_component_arm_disarm):
already armed / disarmed → ACCEPTED; PreArm failures ("AHRS: waiting for home" until home is
set; AP_MotorsUGV::pre_arm_check on the SERVOn_FUNCTIONs, :mod:`helixd.mav.arming`: "no motor,
sail or scripting outputs defined" for a Helix without its spare Script1 output) → FAILED with
one "PreArm: …" CRITICAL STATUSTEXT per failing check unless param2 = 21196 (force);
ARMING_SKIPCHK = -1 skips them (AP_Arming::should_skip_all_checks). Mode
changes (Rover::set_mode, Mode::enter): position-requiring modes are refused while armed
without a good EKF position or in EKF failsafe ("Flight mode change failed"); AUTO is refused
without a mission ("No Mission. Can't set AUTO."). MAV_CMD_MISSION_START (Rover's command
handler) is DENIED with a first or last item (param1/param2 not 0), else it sets AUTO,
armed or not: ACCEPTED, or FAILED when the mode change fails. What AUTO does with the
mission: :mod:`helixd.sim.firmware.mode_auto`.

Home (``Rover::update_home``, ``Rover::set_home``, ``AP_AHRS::set_home``): set where the EKF
puts the rover once it has an origin (``home_delay_s`` after it; ArduPilot: the same loop),
then moved once a second while disarmed when the rover is more than 0.5 m
(DISTANCE_HOME_MINCHANGE) from it, unless locked; MAV_CMD_DO_SET_HOME
(``GCS_MAVLINK::handle_command_do_set_home``) sets it where the rover is (param1 = 1, or x/y
both 0) or at param5/6, and locks it; every change says "Set HOME to …" and sends
HOME_POSITION and GPS_GLOBAL_ORIGIN to every link. The payload commands (relays, camera,
gripper, …) are :mod:`helixd.sim.firmware.payload`'s.

Scripting (AP_Scripting): with SCR_ENABLE 1 at boot the scripts in the working directory's
``scripts/`` are loaded once, when the boot ends. The simulator runs one script:
``helixd-guard.lua``, as its Python mirror (:mod:`helixd.sim.firmware.guard_model`) every 50 ms,
with the parameters the script adds (HXG_*, values kept in storage across reboots) and HXG_VERSION
set to the ``local VERSION`` the file declares. Its actions are applied as the Lua's are:
``set_output_pwm_chan_timeout`` on each guarded output (:meth:`ServoOutputs.hold`), an RC
override of the input feeding an RC-passthrough output, one HOLD request, its STATUSTEXTs.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

from helixd.base.frames import latlon_to_ne, ne_to_latlon
from helixd.mav.arming import (
    ARM_PREFIX,
    FORCE_ARM_MAGIC,
    PREARM_PREFIX,
    motor_prearm_failure,
    servo_functions,
)
from helixd.mav.constants import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_DO_SET_HOME,
    MAV_CMD_DO_SET_MODE,
    MAV_CMD_DO_SET_SERVO,
    MAV_CMD_MISSION_START,
    MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN,
    MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_FAILED,
    MAV_RESULT_UNSUPPORTED,
)
from helixd.mav.guard_script import (
    HXG_VERSION,
    PARAM_DEFAULTS,
    SCR_ENABLE,
    SCRIPT_NAME,
    GuardParams,
    script_version,
)
from helixd.sim.firmware import modes
from helixd.sim.firmware.estimator import SimEkfStatus
from helixd.sim.firmware.failsafe import (
    FailsafeDecision,
    Failsafes,
    battery_failsafe,
    fence_breach,
)
from helixd.sim.firmware.guard_model import (
    HOLD_REFUSED_TEXT,
    UPDATE_PERIOD_MS,
    GuardAction,
    HelixdGuard,
    passthrough_input,
    start_text,
)
from helixd.sim.firmware.outputs import MotorDemand, ServoOutputs
from helixd.sim.firmware.param_store import ParamStore
from helixd.sim.firmware.payload import PAYLOAD_COMMANDS, Payload
from helixd.sim.firmware.rc import RcInputs
from helixd.sim.sim_config import SimConfig

FORCE_REBOOT_MAGIC = 20190226  # GCS_MAVLINK::handle_preflight_reboot: reboot even when armed
MAV_OPTIONS_GCS_ONLY = 1 << 0
SEVERITY_CRITICAL = 2
SEVERITY_WARNING = 4
SEVERITY_NOTICE = 5
NO_MISSION_TEXT = "No Mission. Can't set AUTO."  # ModeAuto::_enter
WPNAV_SPEED_MIN_MPS = 0.05  # AR_WPNAV_SPEED_MIN
SEVERITY_INFO = 6
FIRMWARE_TEXT = "ArduRover V4.7.0-dev (helixd sim)"
DISTANCE_HOME_MINCHANGE_M = 0.5  # Rover/defines.h
HOME_UPDATE_PERIOD_S = 1.0  # Rover::one_second_loop


@dataclass(frozen=True, slots=True)
class Home:
    north_m: float  # of the EKF origin
    east_m: float
    lat_deg: float
    lon_deg: float
    locked: bool


# The autopilot's scripts directory (name → contents), read once per boot; the I/O shell
# (helixd.sim.server) reads it from the working directory.
ScriptReader = Callable[[], Mapping[str, bytes]]


def no_scripts() -> Mapping[str, bytes]:
    """An autopilot without scripts."""
    return {}


@dataclass(slots=True)
class RunningGuard:
    """helixd-guard.lua as loaded at boot: its mirror, the version its file declares, and when
    its update runs next (simulated s)."""

    machine: HelixdGuard
    version: int
    next_s: float


@dataclass(frozen=True, slots=True)
class SimEvent:
    """Something the history log records (mode, arm, override_*, failsafe, ...)."""

    kind: str
    details: Mapping[str, object] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class SimStatusText:
    severity: int
    text: str
    link: int | None = None  # the one link it goes to (None: every link, GCS::send_text)


def _rc_norm(pwm: int, n: int, params: ParamStore) -> float:
    """RC input → −1..1 around RCn_TRIM with its dead zone (RC_Channel::norm_input_dz)."""
    lo, trim, hi = (params.get_int(f"RC{n}_{k}") for k in ("MIN", "TRIM", "MAX"))
    dz = params.get_int(f"RC{n}_DZ")
    if abs(pwm - trim) <= dz:
        return 0.0
    if pwm > trim:
        return min(1.0, (pwm - trim - dz) / max(1, hi - trim - dz))
    return max(-1.0, (pwm - trim + dz) / max(1, trim - lo - dz))


class SimAutopilot:
    def __init__(
        self,
        config: SimConfig,
        params: ParamStore,
        now_s: float = 0.0,
        scripts: ScriptReader = no_scripts,
    ) -> None:
        self.config = config
        self.params = params
        self._scripts = scripts
        self.events: list[SimEvent] = []
        self.texts: list[SimStatusText] = []
        self.pilot_rc_us: list[int] = list(config.pilot_rc_us)
        self.receiver_ok = True
        self.receiver_failsafe_values = False
        self.gcs_heartbeats_seen = 0
        # AP_Mission::present (more than home): the simulator's core answers it
        self.mission_present: Callable[[], bool] = lambda: False
        # AP_SmartRTL::is_active (a saved path): the simulator's core answers it
        self.smart_rtl_ready: Callable[[], bool] = lambda: False
        # AP_Arming_Rover::disarm's own work on the mission: the simulator's core does it
        self.on_disarm: Callable[[], None] = lambda: None
        self._boot(now_s, silent_s=0.0)

    # -- lifecycle -------------------------------------------------------------------------

    def _boot(self, now_s: float, silent_s: float) -> None:
        self.silent_until_s = now_s + silent_s
        self.boot_start_s = self.silent_until_s
        self.boot_end_s = self.boot_start_s + self.config.boot_duration_s
        self.origin_time_s = self.boot_end_s + self.config.ekf_origin_delay_s
        home_delay = self.config.home_delay_s
        self.home_time_s = None if home_delay is None else self.origin_time_s + home_delay
        delay = self.config.prearm_delay_s
        self.prearm_ok_time_s = None if delay is None else self.boot_end_s + delay
        self._motor_check: str | None = None
        self._motor_check_version = -1  # ParamStore.version it was judged at
        self.mode = modes.INITIALISING
        self.armed = False
        self.rc = RcInputs(self.pilot_rc_us)
        self.rc.receiver_ok = self.receiver_ok
        self.rc.failsafe_values = self.receiver_failsafe_values
        self.outputs = ServoOutputs()
        self.payload = Payload()
        self.home: Home | None = None
        self.home_changed = False  # HOME_POSITION (and the origin) go to every link
        self.here_ne: tuple[float, float] | None = None  # the EKF's position, once it has one
        self._next_home_update_s = 0.0
        self.failsafes = Failsafes()
        self.battery_failsafe_level = 0  # 0 none, 1 low, 2 critical (only ever rises)
        self.fence_breached = False
        self.fence_breach_count = 0
        self.fence_breach_ms = 0
        self.mode_switch = modes.ModeSwitch()
        self.gcs_last_seen_s: float | None = None
        self.guard: RunningGuard | None = None
        self._booted = False
        self._origin_announced = False
        self._last_slow_check = -1
        self._overrides_prev: tuple[bool, ...] = (False,) * 16

    def reboot(self, now_s: float, silent_s: float) -> None:
        self.params.on_reboot()
        self.events.append(SimEvent("reboot", {"silent_s": silent_s}))
        self._boot(now_s, silent_s)

    def silent(self, now_s: float) -> bool:
        return now_s < self.silent_until_s

    def booting(self, now_s: float) -> bool:
        return now_s < self.boot_end_s

    def origin_set(self, now_s: float) -> bool:
        return now_s >= self.origin_time_s

    def home_set(self, now_s: float) -> bool:
        """Home is set (from the EKF's position ``home_delay_s`` after the origin, or by
        DO_SET_HOME)."""
        return self.home is not None

    def time_boot_ms(self, now_s: float) -> int:
        return max(0, round((now_s - self.boot_start_s) * 1000.0))

    def loop_rate_hz(self) -> int:
        return int(self.params.boot_value("SCHED_LOOP_RATE"))

    def sysid(self) -> int:
        return int(self.params.boot_value("MAV_SYSID"))

    # -- GCS identity ----------------------------------------------------------------------

    def is_gcs(self, sysid: int) -> bool:
        """GCS::sysid_is_gcs: MAV_GCS_SYSID, or the range up to MAV_GCS_SYSID_HI."""
        lo = self.params.get_int("MAV_GCS_SYSID")
        hi = self.params.get_int("MAV_GCS_SYSID_HI")
        return lo <= sysid <= hi if hi >= lo else sysid == lo

    def accepts_from(self, sysid: int) -> bool:
        """MAV_OPTIONS bit 0: accept MAVLink only from the GCS sysids."""
        return not (self.params.get_int("MAV_OPTIONS") & MAV_OPTIONS_GCS_ONLY) or self.is_gcs(sysid)

    def on_heartbeat(self, sysid: int, now_s: float) -> None:
        if self.is_gcs(sysid):
            self.gcs_last_seen_s = now_s
            self.gcs_heartbeats_seen += 1

    def on_gcs_contact(self, now_s: float) -> None:
        """A message that counts as GCS contact (MANUAL_CONTROL from the GCS, aimed at us)."""
        self.gcs_last_seen_s = now_s

    def on_rc_override(self, sysid: int, raw: Sequence[int], now_s: float) -> None:
        if not self.is_gcs(sysid):
            return  # "Only accept control from our gcs" — silently ignored
        for ev in self.rc.apply_override_message(raw, now_s, self.params.get_int("RC_OPTIONS")):
            self.events.append(
                SimEvent(f"override_{ev.kind}", {"channel": ev.channel, "pwm_us": ev.pwm_us})
            )
        self.gcs_last_seen_s = now_s  # an override counts as GCS contact (sysid_myggcs_seen)

    # -- pilot radio -----------------------------------------------------------------------

    def set_pilot_rc(self, channel: int, pwm_us: int) -> None:
        self.pilot_rc_us[channel - 1] = int(pwm_us)
        self.rc.set_receiver(channel, pwm_us)

    def set_receiver_ok(self, ok: bool) -> None:
        """The pilot's receiver sends frames (or stops: SIM_RC_FAIL 1, no pulses)."""
        self.receiver_ok = ok
        self.rc.receiver_ok = ok

    def set_receiver_failsafe_values(self, on: bool) -> None:
        """The receiver keeps sending, its failsafe frame (SIM_RC_FAIL 2)."""
        self.receiver_failsafe_values = on
        self.rc.failsafe_values = on

    # -- modes and arming ------------------------------------------------------------------

    def _say(self, severity: int, text: str) -> None:
        self.texts.append(SimStatusText(severity, text))

    def set_mode(self, number: int, reason: str, now_s: float, ekf: SimEkfStatus) -> bool:
        if number not in modes.MODE_NAMES or number == modes.INITIALISING:
            self._say(SEVERITY_WARNING, f"No such mode {number}")
            return False
        if number == self.mode:
            return True
        if self.booting(now_s):
            return False
        if (
            self.armed
            and modes.requires_position(number)
            and (not ekf.position_ok or self.failsafes.ekf_failsafe)
        ):
            self._say(SEVERITY_WARNING, "Flight mode change failed")
            return False
        # _enter() refusals: AUTO without a mission (ModeAuto::_enter), SmartRTL with no
        # saved path (ModeSmartRTL::_enter); RTL needs home
        if number == modes.AUTO and not self.mission_present():
            self._say(SEVERITY_NOTICE, NO_MISSION_TEXT)
            self._say(SEVERITY_WARNING, "Flight mode change failed")
            return False
        no_home = number == modes.RTL and not self.home_set(now_s)
        no_path = number == modes.SMART_RTL and not self.smart_rtl_ready()
        if no_path or no_home:
            self._say(SEVERITY_WARNING, "Flight mode change failed")
            return False
        old = self.mode
        self.mode = number
        self.events.append(
            SimEvent(
                "mode",
                {"mode": modes.mode_name(number), "from": modes.mode_name(old), "reason": reason},
            )
        )
        return True

    def prearm_failures(self, now_s: float, ekf: SimEkfStatus) -> list[str]:
        """Every PreArm text an arm would get now (AP_Arming_Rover::pre_arm_checks runs every
        check and reports each failing one): :meth:`prearm_failure`'s, then the motor outputs'
        (AP_Arming_Rover::motor_checks). None with ARMING_SKIPCHK = -1 (all skipped)."""
        if self.params.get_int("ARMING_SKIPCHK") == -1:
            return []
        out = [] if (first := self.prearm_failure(now_s, ekf)) is None else [first]
        motors = self._motor_prearm_failure()
        return out if motors is None else [*out, motors]

    def _motor_prearm_failure(self) -> str | None:
        """AP_MotorsUGV::pre_arm_check over the SERVOn_FUNCTION parameters, judged again only
        when a parameter changed (the telemetry view asks at every step)."""
        version = self.params.version
        if self._motor_check_version != version:
            frame = self.params.get_int("FRAME_TYPE") if "FRAME_TYPE" in self.params else 0
            functions = servo_functions(self.params.as_dict())
            self._motor_check = motor_prearm_failure(functions, frame)
            self._motor_check_version = version
        return self._motor_check

    def prearm_failure(self, now_s: float, ekf: SimEkfStatus) -> str | None:
        """AP_Arming::gps_checks refuses before home is set; the other checks (simulated by
        ``prearm_delay_s``) and the EKF's position after."""
        if not self.home_set(now_s):
            return "AHRS: waiting for home"
        if self.prearm_ok_time_s is None or now_s < self.prearm_ok_time_s:
            return "AHRS: EKF3 still initialising"
        if not ekf.position_ok:
            return "AHRS not healthy"
        if self.failsafes.radio_on():
            return "Radio failsafe on"
        return None

    def arm_check_failure(self) -> str | None:
        """AP_Arming::rc_arm_checks' throttle check, made after the PreArm checks pass: with a
        receiver sending, RCMAP_THROTTLE's channel must read RCn_TRIM ± RCn_DZ."""
        if self.params.get_int("ARMING_SKIPCHK") == -1:
            return None
        if not (self.rc.has_had_receiver and self.rc.receiver_ok) or self.failsafes.radio_on():
            return None
        t_ch = self.params.get_int("RCMAP_THROTTLE")
        if _rc_norm(self.rc.radio_in_us[t_ch - 1], t_ch, self.params) != 0.0:
            return f"Throttle (RC{t_ch}) is not neutral"
        return None

    def _disarm(self, method: str) -> None:
        """AP_Arming::disarm: at once, with what it does to the mission (``on_disarm``)."""
        self.armed = False
        self.events.append(SimEvent("disarm", {"method": method}))
        self.on_disarm()

    def arm_disarm(self, param1: float, param2: float, now_s: float, ekf: SimEkfStatus) -> int:
        if param1 == 0.0:
            if self.armed:
                self._disarm("mavlink")
            return MAV_RESULT_ACCEPTED
        if param1 != 1.0:
            return MAV_RESULT_UNSUPPORTED
        if self.armed:
            return MAV_RESULT_ACCEPTED
        if self.booting(now_s):
            return MAV_RESULT_FAILED
        forced = int(param2) == FORCE_ARM_MAGIC
        if not forced:
            reasons = self.prearm_failures(now_s, ekf)
            for reason in reasons:
                self._say(SEVERITY_CRITICAL, f"{PREARM_PREFIX}{reason}")
            if reasons:
                return MAV_RESULT_FAILED
            refusal = self.arm_check_failure()
            if refusal is not None:
                self._say(SEVERITY_CRITICAL, f"{ARM_PREFIX}{refusal}")
                return MAV_RESULT_FAILED
        self.armed = True
        self.events.append(SimEvent("arm", {"forced": forced}))
        return MAV_RESULT_ACCEPTED

    # -- home --------------------------------------------------------------------------------

    def set_home(self, north_m: float, east_m: float, locked: bool, reason: str) -> None:
        cfg = self.config
        lat, lon = ne_to_latlon(north_m, east_m, cfg.origin_lat_deg, cfg.origin_lon_deg)
        self.home = Home(north_m, east_m, lat, lon, locked)
        self.home_changed = True
        self._say(SEVERITY_INFO, f"Set HOME to {lat:.6f} {lon:.6f} at {cfg.origin_alt_m:.2f}m")
        self.events.append(
            SimEvent(
                "home",
                {"north_m": north_m, "east_m": east_m, "lat_deg": lat, "lon_deg": lon,
                 "locked": locked, "reason": reason},
            )
        )  # fmt: skip

    def observe_position(self, now_s: float, north_m: float, east_m: float, ok: bool) -> None:
        """The EKF's position this loop (``ok``: it has one): home follows it while disarmed
        (Rover::update_home, once a second), the payload's timers and distance trigger run."""
        self.here_ne = (north_m, east_m) if ok else None
        home = self.home
        if ok and home is None:
            # Rover::ahrs_update: home from the EKF's first position (``home_delay_s`` after
            # the origin in the simulator; None: never by itself)
            if self.home_time_s is not None and now_s >= self.home_time_s:
                self._next_home_update_s = now_s + HOME_UPDATE_PERIOD_S
                self.set_home(north_m, east_m, locked=False, reason="ekf")
        elif ok and home is not None and not self.armed and now_s >= self._next_home_update_s:
            self._next_home_update_s = now_s + HOME_UPDATE_PERIOD_S
            if (
                not home.locked
                and math.hypot(north_m - home.north_m, east_m - home.east_m)
                >= DISTANCE_HOME_MINCHANGE_M
            ):
                self.set_home(north_m, east_m, locked=False, reason="update_home")
        for ev in self.payload.update(now_s, self.params, self.outputs, self.here_ne or (0, 0)):
            self.events.append(SimEvent(ev.kind, ev.details))

    def do_set_home(self, p: Sequence[float], is_int: bool) -> int:
        """GCS_MAVLINK::handle_command_do_set_home (COMMAND_LONG's location is converted to
        COMMAND_INT's degE7 first, so x/y 0 means 0 either way)."""
        x, y = p[4], p[5]
        if p[0] == 1.0 or (x == 0.0 and y == 0.0):
            if self.here_ne is None:
                return MAV_RESULT_FAILED
            self.set_home(*self.here_ne, locked=True, reason="DO_SET_HOME current")
            return MAV_RESULT_ACCEPTED
        if p[0] != 0.0:
            return MAV_RESULT_FAILED
        lat, lon = (x / 1e7, y / 1e7) if is_int else (x, y)
        if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
            return MAV_RESULT_DENIED
        cfg = self.config
        north, east = latlon_to_ne(lat, lon, cfg.origin_lat_deg, cfg.origin_lon_deg)
        self.set_home(north, east, locked=True, reason="DO_SET_HOME location")
        return MAV_RESULT_ACCEPTED

    def command(
        self,
        command: int,
        p: Sequence[float],
        now_s: float,
        ekf: SimEkfStatus,
        is_int: bool = False,
    ) -> int | None:
        """Vehicle-level COMMAND_LONG/INT; None = not handled here (the caller decides)."""
        if command == MAV_CMD_COMPONENT_ARM_DISARM:
            return self.arm_disarm(p[0], p[1], now_s, ekf)
        if command == MAV_CMD_DO_SET_MODE:
            return self.do_set_mode(int(p[0]), int(p[1]), now_s, ekf)
        if command == MAV_CMD_DO_SET_HOME:
            return self.do_set_home(p, is_int)
        if command == MAV_CMD_DO_CHANGE_SPEED:
            return self.change_speed(p[0], p[1])
        if command == MAV_CMD_MISSION_START:
            # GCS_MAVLINK_Rover::handle_command_int_packet: a first or last item is DENIED;
            # else AUTO (armed or not: ModeAuto::_enter asks only for a mission)
            if p[0] != 0.0 or p[1] != 0.0:
                return MAV_RESULT_DENIED
            ok = self.set_mode(modes.AUTO, "gcs_command", now_s, ekf)
            return MAV_RESULT_ACCEPTED if ok else MAV_RESULT_FAILED
        if command in PAYLOAD_COMMANDS:
            result, events = self.payload.command(
                command, list(p), self.params, self.outputs, self.here_ne or (0, 0), now_s
            )
            self.events.extend(SimEvent(ev.kind, ev.details) for ev in events)
            return result
        if command == MAV_CMD_DO_SET_SERVO:
            text = self.outputs.do_set_servo(int(p[0]), int(p[1]), self.params)
            repeat = self.payload.repeat
            if text is None and repeat is not None and repeat.servo and repeat.channel == int(p[0]):
                self.payload.repeat = None  # a DO_SET_SERVO cancels a repeat on its output
            if text is None:
                self.events.append(
                    SimEvent("servo_set", {"channel": int(p[0]), "pwm_us": int(p[1])})
                )
                return MAV_RESULT_ACCEPTED
            if text:
                self._say(SEVERITY_INFO, text)
            return MAV_RESULT_FAILED
        if command == MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN:
            # GCS_MAVLINK::handle_preflight_reboot: refused while armed unless forced (param6,
            # COMMAND_INT's y); param1 1 (reboot) or 3 (to the bootloader)
            if self.armed and int(p[5]) != FORCE_REBOOT_MAGIC:
                return MAV_RESULT_FAILED
            if p[0] not in (1.0, 3.0):
                return MAV_RESULT_UNSUPPORTED
            return MAV_RESULT_ACCEPTED  # the caller reboots after sending the ACK
        return None

    def change_speed(self, speed_type: float, speed_mps: float) -> int:
        """Rover's MAV_CMD_DO_CHANGE_SPEED: a climb or descent speed (param1 2, 3, 4) is
        DENIED; else the mode's ``set_desired_speed``: the modes without navigation (MANUAL,
        ACRO, STEERING, HOLD) refuse (FAILED); the navigating ones set AR_WPNav's maximum
        speed, refused under 0.05 m/s (``AR_WPNAV_SPEED_MIN``). Nothing on MAVLink reports the
        new speed (the simulator records it as an event)."""
        if int(speed_type) in (2, 3, 4):
            return MAV_RESULT_DENIED
        if self.mode in modes.NO_POSITION_MODES or not speed_mps >= WPNAV_SPEED_MIN_MPS:
            return MAV_RESULT_FAILED
        self.events.append(SimEvent("speed", {"speed_mps": speed_mps}))
        return MAV_RESULT_ACCEPTED

    def do_set_mode(self, base_mode: int, custom_mode: int, now_s: float, ekf: SimEkfStatus) -> int:
        """GCS_MAVLINK::_set_mode_common: only custom modes are understood."""
        if not base_mode & MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return MAV_RESULT_DENIED
        ok = self.set_mode(custom_mode, "gcs_command", now_s, ekf)
        return MAV_RESULT_ACCEPTED if ok else MAV_RESULT_FAILED

    # -- the main loop ---------------------------------------------------------------------

    def _apply(self, decision: FailsafeDecision, now_s: float, ekf: SimEkfStatus) -> None:
        for severity, text in decision.texts:
            self._say(severity, text)
        if decision.triggered:
            self.events.append(
                SimEvent(
                    "failsafe",
                    {"causes": list(decision.causes), "reported_as": decision.triggered},
                )
            )
        if decision.cleared:
            self.events.append(SimEvent("failsafe_cleared", {"type": decision.cleared}))
        if decision.clear_overrides:
            self.rc.clear_overrides()
            self.events.append(SimEvent("override_clear", {"reason": "failsafe"}))
        for number in decision.modes_to_try:
            if self.set_mode(number, "failsafe", now_s, ekf):
                break
        if decision.disarm and self.armed:
            self._disarm("failsafe")

    def battery_low(
        self, now_s: float, ekf: SimEkfStatus, voltage_v: float, used_mah: float, critical: bool
    ) -> None:
        """Battery 1 reached its low (or critical) limit for BATT_LOW_TIMER: its failsafe
        fires once per level, and acts only while armed."""
        level = 2 if critical else 1
        if not self.armed or level <= self.battery_failsafe_level:
            return
        self.battery_failsafe_level = level
        self._apply(battery_failsafe(voltage_v, used_mah, critical, self.params), now_s, ekf)

    def fence_breach(self, now_s: float, ekf: SimEkfStatus) -> bool:
        """The rover left an enabled fence: True when this is a new breach (the caller
        pushes FENCE_STATUS first, as AC_Fence::record_breach), then FENCE_ACTION if armed."""
        if not self.params.get_int("FENCE_ENABLE") or self.fence_breached:
            return False
        self.fence_breached = True
        self.fence_breach_count += 1
        self.fence_breach_ms = self.time_boot_ms(now_s)
        if self.armed:
            self._apply(fence_breach(self.params), now_s, ekf)
        return True

    def _finish_boot(self, now_s: float) -> None:
        self._booted = True
        initial = self.params.get_int("INITIAL_MODE")
        self.mode = initial if initial in modes.MODE_NAMES else modes.MANUAL
        self.events.append(SimEvent("boot", {"mode": modes.mode_name(self.mode)}))
        self.events.append(
            SimEvent(
                "mode",
                {"mode": modes.mode_name(self.mode), "from": "INITIALISING", "reason": "boot"},
            )
        )
        self._say(SEVERITY_INFO, FIRMWARE_TEXT)
        self._start_scripts(now_s)

    # -- scripting ---------------------------------------------------------------------------

    def _start_scripts(self, now_s: float) -> None:
        """AP_Scripting at boot: only with SCR_ENABLE set when the autopilot booted."""
        if self.params.boot_value(SCR_ENABLE) <= 0:
            return
        source = self._scripts().get(SCRIPT_NAME)
        if source is None:
            return
        version = script_version(source)
        if version is None:
            self._say(SEVERITY_WARNING, f"Lua: {SCRIPT_NAME} is no helixd-guard script (sim)")
            return
        for name, default in PARAM_DEFAULTS.items():
            self.params.add_script_param(name, default)
        self.params.set(HXG_VERSION, float(version))
        params = self._guard_params()
        self.guard = RunningGuard(HelixdGuard(params), version, now_s)
        self.events.append(SimEvent("script", {"name": SCRIPT_NAME, "version": version}))
        self._say(*start_text(params))

    def _guard_params(self) -> GuardParams:
        return GuardParams.from_params({name: self.params.get(name) for name in PARAM_DEFAULTS})

    def _run_guard(self, now_s: float, ekf: SimEkfStatus) -> None:
        """One update of helixd-guard when it is due (every UPDATE_PERIOD_MS)."""
        guard = self.guard
        if guard is None or now_s < guard.next_s - 1e-9:
            return
        period_s = UPDATE_PERIOD_MS / 1000.0
        while guard.next_s <= now_s + 1e-9:  # every 50 ms, as the script's own scheduler;
            guard.next_s += period_s  # here at the first main loop at or after that time
        if self.params.get(HXG_VERSION) != guard.version:  # the Lua re-asserts its version
            self.params.set(HXG_VERSION, float(guard.version))
        guard.machine.params = self._guard_params()
        since_boot = now_s - self.boot_start_s  # millis(): since boot
        last = self.gcs_last_seen_s
        action = guard.machine.step(
            since_boot, self.armed, None if last is None else last - self.boot_start_s, self.mode
        )
        self._apply_guard(action, now_s, ekf)

    def _apply_guard(self, action: GuardAction, now_s: float, ekf: SimEkfStatus) -> None:
        params = self.params
        if action.hold_trim:
            period_ms = 1000.0 / self.loop_rate_hz()
            loops = math.ceil(action.hold_ms / period_ms - 1e-9)
            for n in action.hold_trim:
                trim = params.get_int(f"SERVO{n}_TRIM")
                self.outputs.hold(n, trim, loops)
                source, mapped = passthrough_input(n, params.get_int(f"SERVO{n}_FUNCTION"))
                if source is not None:
                    value = params.get_int(f"RC{source}_TRIM") if mapped else trim
                    self.rc.set_override(source, value, now_s)
        for n in action.release_rc:  # the Lua's set_override(0) on the passthrough inputs
            source, _ = passthrough_input(n, params.get_int(f"SERVO{n}_FUNCTION"))
            if source is not None:
                self.rc.set_override(source, 0, now_s)
        for severity, text in action.texts:
            self._say(severity, text)
            self.events.append(SimEvent("guard", {"guarding": action.guarding, "text": text}))
        if action.request_hold:
            if self.set_mode(modes.HOLD, "helixd_guard", now_s, ekf):
                if self.guard is not None:
                    self.guard.machine.hold_granted()
            else:
                self._say(SEVERITY_WARNING, HOLD_REFUSED_TEXT)

    def motor_demand(self) -> MotorDemand | None:
        if not self.armed:
            return None
        if self.mode in modes.MANUAL_INPUT_MODES:
            t_ch = self.params.get_int("RCMAP_THROTTLE")
            throttle = _rc_norm(self.rc.radio_in_us[t_ch - 1], t_ch, self.params)
            steering = _rc_norm(self.rc.radio_in_us[0], 1, self.params)
            return MotorDemand(throttle, steering)
        return MotorDemand()  # HOLD and the (unsimulated) navigation modes: stop

    def step(self, now_s: float, ekf: SimEkfStatus) -> list[int]:
        """One scheduler loop; returns the 16 servo outputs (µs, 0 = no pulses)."""
        if self.booting(now_s):
            return [0] * 16
        if not self._booted:
            self._finish_boot(now_s)
        if not self._origin_announced and self.origin_set(now_s):
            self._origin_announced = True
            self._say(SEVERITY_INFO, "EKF3 IMU0 origin set")
            self._say(SEVERITY_INFO, "EKF3 IMU0 is using GPS")
        params = self.params
        timeout_s = params.get("RC_OVERRIDE_TIME")
        self.rc.throttle_channel = params.get_int("RCMAP_THROTTLE")
        rc_ok = self.rc.read_input(now_s, timeout_s, params.get_int("RC_OPTIONS"))
        self._note_override_expiry(now_s, timeout_s)
        t_ch = params.get_int("RCMAP_THROTTLE")
        self._apply(
            self.failsafes.radio_check(
                now_s, rc_ok, self.rc.radio_in_us[t_ch - 1], self.mode, params
            ),
            now_s,
            ekf,
        )
        if not self.failsafes.radio_on():
            mode_ch = params.get_int("MODE_CH")
            if 1 <= mode_ch <= 16:
                position = self.mode_switch.update(self.rc.radio_in_us[mode_ch - 1], now_s)
                if position is not None:
                    self.set_mode(params.get_int(f"MODE{position + 1}"), "rc_switch", now_s, ekf)
        self._run_guard(now_s, ekf)
        slow = int(now_s * 10.0)  # the 10 Hz checks
        if slow != self._last_slow_check:
            self._last_slow_check = slow
            self._apply(
                self.failsafes.gcs_check(now_s, self.gcs_last_seen_s, self.mode, params), now_s, ekf
            )
            self._apply(
                self.failsafes.ekf_check(
                    self.armed,
                    ekf,
                    self.origin_set(now_s),
                    modes.requires_position(self.mode),
                    params,
                ),
                now_s,
                ekf,
            )
        return list(self.outputs.update(self.rc.radio_in_us, params, self.motor_demand()))

    def _note_override_expiry(self, now_s: float, timeout_s: float) -> None:
        active = self.rc.active_overrides(now_s, timeout_s)
        for i, (was, now) in enumerate(zip(self._overrides_prev, active, strict=True)):
            if was and not now and self.rc.override_us[i] > 0:
                self.events.append(SimEvent("override_expire", {"channel": i + 1}))
        self._overrides_prev = active
