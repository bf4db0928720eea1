"""Safety watchdogs: pure decisions, stepped with a snapshot and two clocks.

No sockets, clocks or logging here. The supervisor (:mod:`helixd.safety.supervisor`) feeds a
:class:`SafetyInputs` snapshot each control tick and acts on the first :class:`Fault` returned.

Which clock each watchdog counts on (a simulator speed-up makes the autopilot's run faster than
ours; a dead or rebooting autopilot has no clock at all):

- ``link_lost``, ``pose_stale``, ``pose_invalid``: our *reception* of its messages. Monotonic
  wall clock (``now_s`` against ``last_heartbeat_s`` / ``pose_rx_s``): a silent autopilot sends
  no time, so only our own clock can notice its silence.
- ``stall``: how long the *vehicle* has been commanded but not moving. Autopilot time
  (``vehicle_time_s``, the ``time_boot_ms`` of the latest pose): the duration is a property of
  the rover's motion, so a speed-up must not stretch it in vehicle terms. It only advances with
  fresh poses; pose loss is ``pose_stale``'s job. A clock that runs backwards (reboot) restarts
  the timer. Without an autopilot clock (no pose yet) the wall clock is used, and switching
  between the two restarts the timer rather than mixing them.
- ``mission_time``: the later of both clocks (computed by the flight loop as
  ``mission_elapsed_s``): the plan's estimate is autopilot time, and a reboot restarts that.
  Driving time only: the time held for the crew (paused in HOLD, at the autopilot's place,
  at a NAV_LOITER_UNLIM) is left out (``mission_paused_s``, :mod:`helixd.safety.mission_clock`).
- ``gps_lost``: the fix and satellites of the latest GPS_RAW_INT are states, judged at once;
  the stream's silence is our reception of it (``gps_rx_s``, wall clock, ``gps_stale_s``), and
  so is a receiver that stopped sending (``gps_fix_rx_s``: when GPS_RAW_INT's ``time_usec``
  last changed; ArduPilot repeats the last fix, time frozen, for 4 s before it says "no GPS").
  ArduPilot's receivers fix at 5-20 Hz (GPS_RATE_MS 50-200 ms of autopilot time), so we see
  the time move at least every GPS_RAW_INT period plus 0.2 s, inside ``gps_stale_s`` (the
  config check) unless a simulator runs far slower than real time.
  The EKF dead-reckons for seconds after a GPS loss before it drops its position (observed
  on ArduPilot SITL: 7.3 s, 4.8 m), so this rule, not ``ekf_unhealthy``, stops the scrolls.
- ``ekf_unhealthy``, ``disarmed``, ``pilot_takeover``, ``rc_lost``, ``geofence``: states, judged
  at once; no clock.

NaN is never "fine": a non-finite input a watchdog needs is itself a fault (a comparison with
NaN is False, so every rule is written so that False means "fault", or checks finiteness first).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum
from operator import itemgetter

from helixd.base.polygon import point_in_polygon
from helixd.config.safety import SafetyConfig

RC_CENTRE_US = 1500  # stick centre of a standard RC channel (µs)
MODE_CHANGED_PREFIX = "mode changed to "  # a takeover by mode change: the detail's start
MODE_EXPECTED_PREFIX = "(helixd set "


class FaultCause(StrEnum):
    LINK_LOST = "link_lost"  # no autopilot HEARTBEAT
    POSE_STALE = "pose_stale"  # LOCAL_POSITION_NED/ATTITUDE stopped
    POSE_INVALID = "pose_invalid"  # pose telemetry non-finite, absurd or out of order
    EKF_UNHEALTHY = "ekf_unhealthy"
    PILOT_TAKEOVER = "pilot_takeover"  # mode change, RC switch or stick deflection
    RC_LOST = "rc_lost"  # the pilot's radio is gone: nobody could take over
    DISARMED = "disarmed"  # someone disarmed (or the autopilot rebooted) mid-mission
    GEOFENCE = "geofence"
    MISSION_TIME = "mission_time"
    STALL = "stall"  # scrolls commanded, rover not moving: the sand pit of field test 1
    SIGNAL = "signal"  # SIGINT / SIGTERM
    PAUSED = "paused"  # helixd serve: the operator paused (start switch low, DO_PAUSE_CONTINUE)
    # helixd serve, a flight the autopilot's AUTO drives: the crew chose a mode the pilot
    # drives (MANUAL, ACRO, STEERING): overrides released at once, no HOLD asked
    RELEASED = "released"
    # helixd serve, a flight of AUTO: the crew set the autopilot's current item (not the next
    # one): the flight ends without asking HOLD and the next starts at that item
    ITEM_SET = "item_set"
    # a completed mission's disarm failed: the vehicle is left armed, so it is no exit 0
    NOT_DISARMED = "not_disarmed"
    # helixd serve, a flight the autopilot's mode drives: the crew gave the autopilot another
    # place (Go to location) or a mode helixd drives in (AUTO, GUIDED, RTL, SMART_RTL): the
    # flight ends without asking HOLD and the next drives there
    HANDOVER = "handover"
    EXCEPTION = "exception"  # unhandled error inside helixd
    PREFLIGHT = "preflight"  # refused before the mission started (nothing driven)
    ACTUATOR = "actuator"  # the actuator backend refused a command mid-mission (servo)
    GPS_LOST = "gps_lost"  # fix below the minimum, too few satellites or GPS_RAW_INT stopped
    # ArduPilot's own failsafe changed the mode (helixd.safety.autopilot_failsafe names it)
    AUTOPILOT_BATTERY = "autopilot_battery"  # BATT_FS_LOW_ACT / BATT_FS_CRT_ACT
    AUTOPILOT_FENCE = "autopilot_fence"  # FENCE_ACTION on a breach of the autopilot's fence
    AUTOPILOT_RADIO = "autopilot_radio"  # FS_THR_ENABLE: "Radio Failsafe", FS_ACTION
    AUTOPILOT_GCS = "autopilot_gcs"  # FS_GCS_ENABLE: "GCS Failsafe", FS_ACTION
    AUTOPILOT_EKF = "autopilot_ekf"  # FS_EKF_ACTION: "EKF failsafe"
    AUTOPILOT_FAILSAFE = "autopilot_failsafe"  # a failsafe (system_status CRITICAL), no text


# The crew's hand-over of a flight in the autopilot's own mode: the next flight drives (a new
# current item, a new place or mode helixd drives in) ...
NEXT_FLIGHT_CAUSES = frozenset({FaultCause.ITEM_SET, FaultCause.HANDOVER})
# ... or the pilot does (RELEASED): no HOLD asked, nothing disarmed, the mission's verdict stands
HANDED_CAUSES = frozenset({FaultCause.RELEASED, *NEXT_FLIGHT_CAUSES})
# The crew stopped the flight (an operator's pause, a stop signal): no fault, and a continue
# goes on from where it stopped.
STOP_CAUSES = frozenset({FaultCause.SIGNAL, FaultCause.PAUSED})
# Causes that mean "a human took over or asked to stop", not "something broke".
OPERATOR_CAUSES = frozenset({FaultCause.PILOT_TAKEOVER, *STOP_CAUSES, *HANDED_CAUSES})


# What each cause is called where a person reads it (a ground station's messages on a tablet):
# words, not the identifiers the logs, the result line and summary.json keep.
CAUSE_WORDS: dict[str, str] = {
    FaultCause.LINK_LOST: "autopilot link lost",
    FaultCause.POSE_STALE: "position lost",
    FaultCause.POSE_INVALID: "bad position data",
    FaultCause.EKF_UNHEALTHY: "EKF unhealthy",
    FaultCause.PILOT_TAKEOVER: "pilot took over",
    FaultCause.RC_LOST: "pilot's radio lost",
    FaultCause.DISARMED: "disarmed",
    FaultCause.GEOFENCE: "outside the geofence",
    FaultCause.MISSION_TIME: "time limit reached",
    FaultCause.STALL: "stuck, not moving",
    FaultCause.SIGNAL: "stopped on the rover",
    FaultCause.PAUSED: "paused",
    FaultCause.RELEASED: "released to the pilot",
    FaultCause.ITEM_SET: "new current item",
    FaultCause.NOT_DISARMED: "mission done, still armed",
    FaultCause.HANDOVER: "driving to a new place",
    FaultCause.EXCEPTION: "internal error",
    FaultCause.PREFLIGHT: "preflight refused",
    FaultCause.ACTUATOR: "scroll command refused",
    FaultCause.GPS_LOST: "GPS lost",
    FaultCause.AUTOPILOT_BATTERY: "battery failsafe",
    FaultCause.AUTOPILOT_FENCE: "fence failsafe",
    FaultCause.AUTOPILOT_RADIO: "radio failsafe",
    FaultCause.AUTOPILOT_GCS: "GCS failsafe",
    FaultCause.AUTOPILOT_EKF: "EKF failsafe",
    FaultCause.AUTOPILOT_FAILSAFE: "autopilot failsafe",
    "fallback": "stop incomplete",  # the fall-back itself failed (HOLD refused, …)
}


def cause_words(cause: str) -> str:
    """A cause as a person reads it (``pose_stale`` → "position lost"); a name without an
    entry with its underscores as spaces."""
    return CAUSE_WORDS.get(cause, cause.replace("_", " "))


@dataclass(frozen=True, slots=True)
class Fault:
    cause: FaultCause
    detail: str

    @property
    def changed_mode(self) -> str | None:
        """The mode a takeover by mode change saw (None for any other fault)."""
        modes = self.mode_change
        return None if modes is None else modes[0]

    @property
    def mode_change(self) -> tuple[str, str] | None:
        """(the mode seen, the mode helixd set) of a takeover by mode change, else None."""
        if self.cause is not FaultCause.PILOT_TAKEOVER:
            return None
        if not self.detail.startswith(MODE_CHANGED_PREFIX):
            return None
        seen, _, rest = self.detail.removeprefix(MODE_CHANGED_PREFIX).partition(" ")
        expected = rest.removeprefix(MODE_EXPECTED_PREFIX).removesuffix(")")
        return (seen, expected) if seen and expected else None


@dataclass(frozen=True, slots=True)
class SafetyInputs:
    """Everything the watchdogs look at, at one instant (monotonic seconds)."""

    now_s: float
    last_heartbeat_s: float | None
    pose_rx_s: float | None
    ekf_healthy: bool | None
    ekf_detail: str
    mode: str
    expected_mode: str
    armed: bool
    rc_inputs_us: Sequence[int]
    north_m: float | None
    east_m: float | None
    start_north_m: float
    start_east_m: float
    mission_elapsed_s: float  # driving time: the time held for the crew is left out
    commanded_speed_mps: float
    measured_speed_mps: float
    commanded_yaw_rate_radps: float = 0.0
    measured_yaw_rate_radps: float = 0.0
    rc_receiver_healthy: bool | None = None
    # start of the current burst of rejected pose telemetry (None: the last pose was valid)
    pose_invalid_since_s: float | None = None
    pose_invalid_detail: str = ""
    # autopilot clock (s since its boot) of the latest pose; None: no pose yet
    vehicle_time_s: float | None = None
    # GPS_RAW_INT: judged only when gps_monitored (the supervisor always sets it)
    gps_monitored: bool = False
    gps_rx_s: float | None = None  # our reception of the latest GPS_RAW_INT
    # our reception of the latest GPS_RAW_INT with a new time_usec (a new fix); None: gps_rx_s
    gps_fix_rx_s: float | None = None
    gps_fix_type: int | None = None  # GPS_FIX_TYPE; None: never received or out of range
    gps_satellites: int | None = None  # None: unknown
    mission_paused_s: float = 0.0  # held for the crew, not in mission_elapsed_s (for the text)
    # the link says it is lost (the transport closed, the HEARTBEAT silent): its cause; None: up
    link_lost_cause: str | None = None
    last_rx_s: float | None = None  # our reception of the autopilot's latest message, any kind
    # the crawl watch (stall.crawl_fraction) applies: the rover rolls. Rolling delivers 0.3 or
    # more of its command on every ground it can roll on and 0.05 afloat, so under a tenth is
    # water or a pit; scrolling's slowest ground (hard, sand: 0.12) is too near a tenth to tell
    # slow from stuck, and the stopped-rover watch covers it
    crawl_watch: bool = True


def _finite(*values: float | None) -> bool:
    isfinite = math.isfinite
    for v in values:  # noqa: SIM110 - a plain loop: no generator frame on the hot path
        if v is not None and not isfinite(v):
            return False
    return True


def age_fault(
    cause: FaultCause, now_s: float, rx_s: float | None, limit_s: float, never: str, old: str
) -> Fault | None:
    """A fault of ``cause`` when nothing was received (``never``) or the last is older than
    ``limit_s`` (``old``, formatted with its ``age`` and the ``limit``); None otherwise (a
    NaN age is old)."""
    if rx_s is None:
        return Fault(cause, never)
    age = now_s - rx_s
    if not age <= limit_s:
        return Fault(cause, old.format(age=age, limit=limit_s))
    return None


def pose_invalid_fault(
    now_s: float,
    pose_rx_s: float | None,
    invalid_since_s: float | None,
    detail: str,
    limit_s: float,
    what: str = "pose",
) -> Fault | None:
    """Pose telemetry rejected for longer than ``limit_s`` (the stale-pose limit), measured
    from the last valid pose, or from the first rejection when there never was one.

    The pose-stale rule would fire at the same moment (rejected poses are never stored, so the
    pose ages); this one names the reason. Shared by the watchdog and the daemon's start-pose
    path."""
    if invalid_since_s is None:
        return None
    since = invalid_since_s if pose_rx_s is None else min(invalid_since_s, pose_rx_s)
    invalid_s = now_s - since
    if invalid_s <= limit_s:
        return None
    return Fault(
        FaultCause.POSE_INVALID,
        f"no valid {what} for {invalid_s:.2f} s (limit {limit_s} s): "
        f"{detail or 'pose telemetry rejected'}",
    )


GPS_FIX_NAMES = {
    0: "no GPS",
    1: "no fix",
    2: "2D fix",
    3: "3D fix",
    4: "DGPS",
    5: "RTK float",
    6: "RTK fixed",
    7: "static",
    8: "PPP",
}


def starved_by_silence(
    now_s: float,
    rx_s: float | None,
    limit_s: float,
    last_rx_s: float | None,
    last_heartbeat_s: float | None,
) -> bool:
    """Whether a stream received last at ``rx_s`` is overdue (older than ``limit_s``) only
    because nothing at all has come since it was due: the whole link stopped, and the link
    watchdog names that within ``pose_stale_s`` of the silence, whatever the stream's phase. A
    stream that alone stopped is overdue with other messages still arriving after its due
    time, and is judged as itself."""
    if rx_s is None or last_rx_s is None or last_heartbeat_s is None:
        return False
    return now_s - rx_s > limit_s and last_rx_s <= rx_s + limit_s


def gps_fault(
    now_s: float,
    rx_s: float | None,
    fix_type: int | None,
    satellites: int | None,
    cfg: SafetyConfig,
    fix_rx_s: float | None = None,
) -> Fault | None:
    """The GPS is not good enough to drive on: no GPS_RAW_INT for ``gps_stale_s`` (the stream
    stopped), a fix below ``gps_min_fix_type``, fewer than ``gps_min_satellites``, or no new
    fix for ``gps_stale_s`` (``fix_rx_s``, when its ``time_usec`` last changed; None: as
    ``rx_s``): the receiver stopped while ArduPilot repeats its last fix. Shared by the
    watchdog and preflight. Unknown (None) is never good enough."""
    if rx_s is None:
        return Fault(FaultCause.GPS_LOST, "no GPS_RAW_INT received")
    age = now_s - rx_s
    if not age <= cfg.gps_stale_s:
        return Fault(
            FaultCause.GPS_LOST,
            f"GPS_RAW_INT stopped: the latest is {age:.2f} s old (limit {cfg.gps_stale_s} s)",
        )
    want = cfg.gps_min_fix_type
    if fix_type is None or fix_type < want:
        have = "unknown" if fix_type is None else GPS_FIX_NAMES.get(fix_type, str(fix_type))
        return Fault(
            FaultCause.GPS_LOST,
            f"GPS fix {have} (fix_type {fix_type}), below the minimum "
            f"{GPS_FIX_NAMES.get(want, str(want))} (fix_type {want})",
        )
    if satellites is None or satellites < cfg.gps_min_satellites:
        return Fault(
            FaultCause.GPS_LOST,
            f"GPS sees {'an unknown number of' if satellites is None else satellites} "
            f"satellites (minimum {cfg.gps_min_satellites})",
        )
    fix_age = now_s - (rx_s if fix_rx_s is None else fix_rx_s)
    if not fix_age <= cfg.gps_stale_s:
        return Fault(
            FaultCause.GPS_LOST,
            f"the GPS receiver stopped: GPS_RAW_INT repeats a fix {fix_age:.2f} s old "
            f"(time_usec unchanged; limit {cfg.gps_stale_s} s)",
        )
    return None


class SafetyMonitor:
    """All watchdogs of the fall-back (docs/architecture.md, safety invariants).

    Pure apart from the stall timer it carries.
    """

    def __init__(self, cfg: SafetyConfig) -> None:
        self.cfg = cfg
        self._stall_since_s: float | None = None
        self._stall_on_vehicle_clock = False  # which clock _stall_since_s counts on
        # the crawl watch: (t_s, commanded m, delivered m) per step over stall.duration_s
        self._crawl: deque[tuple[float, float, float]] = deque()
        self._crawl_last: tuple[float, bool] | None = None  # (t_s, on the vehicle clock)

    def reset(self) -> None:
        self._stall_since_s = None
        self._crawl.clear()
        self._crawl_last = None

    def check(self, s: SafetyInputs) -> Fault | None:
        """Return the first fault found, in order of how directly it endangers the rover."""
        for rule in (
            self._inputs_finite,
            self._link,
            self._pose_invalid,
            self._pose,
            self._ekf,
            self._gps,
            self._armed,
            self._takeover,
            self._rc_receiver,
            self._geofence,
            self._time,
            self._stall,
            self._crawling,
        ):
            fault = rule(s)
            if fault is not None:
                return fault
        return None

    def _inputs_finite(self, s: SafetyInputs) -> Fault | None:
        """Non-finite numbers the watchdogs rely on: no rule could judge them."""
        if not _finite(
            s.now_s,
            s.last_heartbeat_s,
            s.pose_rx_s,
            s.mission_elapsed_s,
            s.vehicle_time_s,
            s.gps_rx_s,
            s.gps_fix_rx_s,
            s.last_rx_s,
        ):
            return Fault(FaultCause.EXCEPTION, "non-finite clock value in the safety inputs")
        if not _finite(s.commanded_speed_mps, s.commanded_yaw_rate_radps):
            return Fault(FaultCause.EXCEPTION, "non-finite command in the safety inputs")
        if not _finite(s.start_north_m, s.start_east_m):
            return Fault(FaultCause.POSE_INVALID, "start pose is not finite")
        if not _finite(s.north_m, s.east_m, s.measured_speed_mps, s.measured_yaw_rate_radps):
            return Fault(
                FaultCause.POSE_INVALID,
                f"pose not finite (N {s.north_m}, E {s.east_m}, speed {s.measured_speed_mps}, "
                f"yaw rate {s.measured_yaw_rate_radps})",
            )
        return None

    def _link(self, s: SafetyInputs) -> Fault | None:
        """The link, named first whatever else its loss starves: a transport closed (a pulled
        cable) at once, and an autopilot silent in every message longer than a pose may be
        old (the pose, GPS and HEARTBEAT all stopped together: the link, not the GPS)."""
        if s.link_lost_cause is not None:
            return Fault(FaultCause.LINK_LOST, s.link_lost_cause or "the link says so")
        heard = s.last_heartbeat_s is not None and s.last_rx_s is not None
        silent_s = s.now_s - s.last_rx_s if heard and s.last_rx_s is not None else None
        if silent_s is not None and not silent_s <= self.cfg.pose_stale_s:
            text = f"no message from the autopilot for {silent_s:.2f} s"
            return Fault(FaultCause.LINK_LOST, text)
        return age_fault(
            FaultCause.LINK_LOST,
            s.now_s,
            s.last_heartbeat_s,
            self.cfg.heartbeat_timeout_s,
            "no HEARTBEAT received from the autopilot",
            "no autopilot HEARTBEAT for {age:.2f} s (limit {limit} s)",
        )

    def _pose_invalid(self, s: SafetyInputs) -> Fault | None:
        return pose_invalid_fault(
            s.now_s,
            s.pose_rx_s,
            s.pose_invalid_since_s,
            s.pose_invalid_detail,
            self.cfg.pose_stale_s,
        )

    def _pose(self, s: SafetyInputs) -> Fault | None:
        stale_s = self.cfg.pose_stale_s
        if starved_by_silence(s.now_s, s.pose_rx_s, stale_s, s.last_rx_s, s.last_heartbeat_s):
            return None  # every message stopped: _link names it
        return age_fault(
            FaultCause.POSE_STALE,
            s.now_s,
            s.pose_rx_s,
            self.cfg.pose_stale_s,
            "no pose received",
            "pose is {age:.2f} s old (limit {limit} s)",
        )

    def _ekf(self, s: SafetyInputs) -> Fault | None:
        if s.ekf_healthy is False:
            return Fault(FaultCause.EKF_UNHEALTHY, s.ekf_detail or "EKF reports unhealthy")
        return None

    def _gps(self, s: SafetyInputs) -> Fault | None:
        if not s.gps_monitored:
            return None
        stale_s = self.cfg.gps_stale_s
        if starved_by_silence(s.now_s, s.gps_rx_s, stale_s, s.last_rx_s, s.last_heartbeat_s):
            return None  # every message stopped: _link names it
        return gps_fault(
            s.now_s, s.gps_rx_s, s.gps_fix_type, s.gps_satellites, self.cfg, s.gps_fix_rx_s
        )

    def _armed(self, s: SafetyInputs) -> Fault | None:
        if not s.armed:
            return Fault(FaultCause.DISARMED, f"vehicle disarmed mid-mission (mode {s.mode})")
        return None

    def _takeover(self, s: SafetyInputs) -> Fault | None:
        t = self.cfg.takeover
        if t.on_mode_change and s.mode != s.expected_mode:
            return Fault(
                FaultCause.PILOT_TAKEOVER,
                f"{MODE_CHANGED_PREFIX}{s.mode} {MODE_EXPECTED_PREFIX}{s.expected_mode})",
            )
        rc = s.rc_inputs_us
        if t.switch_channel is not None and len(rc) >= t.switch_channel:
            pwm = rc[t.switch_channel - 1]
            if pwm >= t.switch_threshold_us:
                return Fault(
                    FaultCause.PILOT_TAKEOVER,
                    f"takeover switch RC{t.switch_channel} at {pwm} µs "
                    f"(>= {t.switch_threshold_us} µs)",
                )
        for ch in t.stick_channels:
            if 1 <= ch <= len(rc) and rc[ch - 1] > 0:
                deflection = abs(rc[ch - 1] - RC_CENTRE_US)
                if deflection > t.stick_deflection_us:
                    return Fault(
                        FaultCause.PILOT_TAKEOVER,
                        f"stick RC{ch} deflected {deflection} µs (> {t.stick_deflection_us} µs)",
                    )
        return None

    def _rc_receiver(self, s: SafetyInputs) -> Fault | None:
        if self.cfg.stop_on_rc_loss and s.rc_receiver_healthy is False:
            return Fault(
                FaultCause.RC_LOST,
                "the pilot's RC receiver is unhealthy (SYS_STATUS): nobody could take over",
            )
        return None

    def _geofence(self, s: SafetyInputs) -> Fault | None:
        if s.north_m is None or s.east_m is None:
            return None
        if not _finite(s.north_m, s.east_m, s.start_north_m, s.start_east_m):
            return Fault(FaultCause.GEOFENCE, "position not finite: the fence cannot be checked")
        radius = self.cfg.geofence_radius_m
        if radius is not None:
            dist = math.hypot(s.north_m - s.start_north_m, s.east_m - s.start_east_m)
            if not dist <= radius:
                return Fault(
                    FaultCause.GEOFENCE,
                    f"{dist:.1f} m from the start point (limit {radius} m)",
                )
        poly = self.cfg.geofence_polygon_ne_m
        if len(poly) >= 3 and not point_in_polygon(s.north_m, s.east_m, poly):
            return Fault(
                FaultCause.GEOFENCE,
                f"outside the keep-in polygon at N {s.north_m:.1f} m E {s.east_m:.1f} m",
            )
        return None

    def _time(self, s: SafetyInputs) -> Fault | None:
        limit = self.cfg.mission_time_limit_s
        if not s.mission_elapsed_s <= limit:
            paused = (
                f"; {s.mission_paused_s:.0f} s paused not counted" if s.mission_paused_s else ""
            )
            return Fault(
                FaultCause.MISSION_TIME,
                f"driving {s.mission_elapsed_s:.0f} s (limit {limit:.0f} s{paused})",
            )
        return None

    def _stall(self, s: SafetyInputs) -> Fault | None:
        st = self.cfg.stall
        # A non-finite command counts as commanded, a non-finite measurement as not moving.
        not_moving = not s.measured_speed_mps >= st.measured_speed_max_mps
        driving_stuck = not s.commanded_speed_mps <= st.commanded_speed_min_mps and not_moving
        turning_stuck = (
            not abs(s.commanded_yaw_rate_radps) <= st.commanded_yaw_rate_min_radps
            and not abs(s.measured_yaw_rate_radps) >= st.measured_yaw_rate_max_radps
            and not_moving
        )
        if not (driving_stuck or turning_stuck):
            self._stall_since_s = None
            return None
        on_vehicle_clock = s.vehicle_time_s is not None
        t_s = s.vehicle_time_s if s.vehicle_time_s is not None else s.now_s
        if (
            self._stall_since_s is None
            or on_vehicle_clock != self._stall_on_vehicle_clock
            or not t_s >= self._stall_since_s  # clock ran backwards (reboot) or NaN
        ):
            self._stall_since_s = t_s
            self._stall_on_vehicle_clock = on_vehicle_clock
        stuck_s = t_s - self._stall_since_s
        if stuck_s < st.duration_s:
            return None
        what = (
            f"commanded {s.commanded_speed_mps:.2f} m/s but moving {s.measured_speed_mps:.2f} m/s"
            if driving_stuck
            else f"commanded turn {s.commanded_yaw_rate_radps:.2f} rad/s but turning "
            f"{s.measured_yaw_rate_radps:.2f} rad/s"
        )
        return Fault(FaultCause.STALL, f"{what} for {stuck_s:.1f} s (scrolls dug in?)")

    def _crawling(self, s: SafetyInputs) -> Fault | None:
        """A rover that moves, but at under ``stall.crawl_fraction`` of its command over the
        last ``stall.duration_s`` (rolling in water delivers about 0.05: it crawls at a few
        cm/s, above ``measured_speed_max_mps`` now and then, and never gets anywhere) is stuck
        too. Judged on the travel commanded and delivered over the window, while the command
        stays above ``commanded_speed_min_mps`` (a stop, a turn in place or the start of a
        leg restart it), on the stall's clock."""
        st = self.cfg.stall
        on_vehicle_clock = s.vehicle_time_s is not None
        t_s = s.vehicle_time_s if s.vehicle_time_s is not None else s.now_s
        last = self._crawl_last
        if (
            st.crawl_fraction <= 0.0
            or not s.crawl_watch
            or not s.commanded_speed_mps > st.commanded_speed_min_mps
            or not math.isfinite(t_s)
            or (last is not None and (last[1] != on_vehicle_clock or not t_s >= last[0]))
        ):
            self._crawl.clear()
            self._crawl_last = None if st.crawl_fraction <= 0.0 else (t_s, on_vehicle_clock)
            return None
        self._crawl_last = (t_s, on_vehicle_clock)
        if last is None or t_s == last[0]:
            return None
        dt_s = t_s - last[0]
        measured = s.measured_speed_mps if math.isfinite(s.measured_speed_mps) else 0.0
        self._crawl.append((t_s, s.commanded_speed_mps * dt_s, measured * dt_s))
        while self._crawl and t_s - self._crawl[0][0] > st.duration_s:
            self._crawl.popleft()
        first_t = self._crawl[0][0]
        span_s = t_s - first_t + dt_s
        if span_s < st.duration_s:
            return None
        # the same sums in the same order as a generator's, without a frame per window entry
        commanded_m = sum(map(itemgetter(1), self._crawl))
        delivered_m = sum(map(itemgetter(2), self._crawl))
        if not delivered_m < st.crawl_fraction * commanded_m:
            return None
        pct = 100.0 * delivered_m / commanded_m if commanded_m > 0.0 else 0.0
        return Fault(
            FaultCause.STALL,
            f"moved {delivered_m:.2f} m of {commanded_m:.2f} m commanded in {span_s:.1f} s "
            f"({pct:.0f}%, below stall.crawl_fraction {st.crawl_fraction:g}): stuck, not slip",
        )
