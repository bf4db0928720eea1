"""The setup phases of a flight, as functions over the link and the config: connect, preflight
(the vehicle, its servo outputs, a fresh pose, the EKF origin; then the mission placed from the
rover's pose), the pilot's start gate, the autopilot's home, arming and the confirmations that
a mode change or an arm happened. :class:`helixd.runtime.daemon.MissionRunner` calls them in
order; each returns what it found or raises.

In runtime/, beside the runner: they need the link and the config, and also the safety
layer's faults (a pose rejected too long) and the actuators (the sink sends neutral first).

What setup has taken hold of (the link, the sink, "we armed it") is written to the
:class:`Held` ledger as soon as it is held, so the runner's shutdown gives it back whatever
stopped setup half way. A stop signal ends any wait (:func:`until_stopped`) with
:class:`StopBeforeFlight`; a refusal is :class:`PreflightFailed` (one line per problem).
"""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections.abc import AsyncIterator, Awaitable, Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TypeVar

import structlog

from helixd.actuators.base import ActuatorSink
from helixd.actuators.factory import make_sink
from helixd.base.clock import now_s
from helixd.base.frames import MissionFrame, NedPose, latlon_to_ne
from helixd.base.plan import MissionFrameKind, Numbering, Plan, program_numbering
from helixd.base.problems import Problems
from helixd.base.run_files import TLOG_FILE
from helixd.base.tasks import stop_task
from helixd.config.root import HelixdConfig
from helixd.config.safety import SafetyConfig
from helixd.config.vehicle import ActuationBackend
from helixd.link.connection import Autopilot
from helixd.link.services.command_client import CommandError, CommandRejected
from helixd.link.services.preflight import check_obedience
from helixd.link.telemetry import Telemetry
from helixd.link.vehicle import Change, HomePosition, TelemetryBounds, VehicleState
from helixd.link.wire.tlog import LinkTlog, attach_tlog
from helixd.mav.arming import not_neutral_channel, rc_reading, throttle_must_read
from helixd.mav.constants import (
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_REQUEST_MESSAGE,
    MAVLINK_MSG_ID_HOME_POSITION,
)
from helixd.mav.servo_functions import DO_SET_SERVO_FUNCTIONS, passthrough_input
from helixd.mission.commands import SERVO_COMMANDS, stored_whole
from helixd.mission.expand import ExpandOptions
from helixd.mission.judge import judge_flight
from helixd.mission.model import Mission
from helixd.mission.resolve import Where, resolve
from helixd.mission.resume import RunInputs, with_leg_start
from helixd.prepare.media import MediaRefused, media_path, placed_media_plan
from helixd.prepare.planned import Replanner
from helixd.report.notify import ServiceNotifier
from helixd.runtime.autopilot_fence import autopilot_fence_check
from helixd.runtime.show_plan import show_plan
from helixd.runtime.signals import StopRequest
from helixd.safety.watchdogs import Fault, FaultCause, gps_fault, pose_invalid_fault

log = structlog.get_logger(__name__)
# how often a confirmation asks the autopilot for a HEARTBEAT (s): a few of its control
# periods, so an answer built before the change took effect is followed by one after it
HEARTBEAT_ASK_S = 0.1
T = TypeVar("T")


# AP_ServoRelayEvents::do_set_servo: the output functions a servo command may move (none,
# manual, sprayer pump/spinner, gripper, RCIN1..16 passthrough, RCIN1..16 mapped)
class PreflightFailed(Problems):
    joiner = "; "


class StopBeforeFlight(Exception):
    """A signal arrived before the mission started (nothing was armed)."""


class StartRefused(Exception):
    """Armed, but the mission cannot start: the pose telemetry is being rejected (no valid
    start pose), or the rover was moved during the start gate to where the mission would leave
    the geofence. A fault: the fall-back runs."""

    def __init__(self, fault: Fault, detected_s: float) -> None:
        self.fault = fault
        self.detected_s = detected_s
        super().__init__(fault.detail)


@dataclass
class Held:
    """What setup has taken hold of so far: what shutdown must give back.

    Filled as setup goes (a preflight can fail after the sink sent its first neutral), read
    by shutdown only, which copes with every field unset.
    """

    ap: Autopilot | None = None
    sink: ActuatorSink | None = None
    armed_by_us: bool = False


@dataclass(frozen=True)
class Vehicle:
    """What the vehicle's preflight found: the start pose and the EKF origin (None: not sent;
    a global mission is refused without it)."""

    pose: NedPose
    origin: tuple[float, float] | None


@dataclass(frozen=True)
class Checked:
    """What preflight found: the start pose, the EKF origin, the mission as flown (its first
    leg re-planned from the rover when it was planned around obstacles), its plan, the config
    in force for it from that pose (the mission's own fence placed exactly, its time limit and
    ground) and the autopilot's home (missions with commands)."""

    start_ned: NedPose
    origin: tuple[float, float] | None
    plan: Plan
    mission: Mission
    cfg: HelixdConfig
    home: HomePosition | None = None


async def until_stopped(stop: StopRequest, awaitable: Awaitable[T]) -> T:
    """Await ``awaitable`` unless a stop signal arrives first (:class:`StopBeforeFlight`)."""
    task = asyncio.ensure_future(awaitable)
    stopper = asyncio.ensure_future(stop.event.wait())
    try:
        done, _ = await asyncio.wait({task, stopper}, return_when=asyncio.FIRST_COMPLETED)
    finally:
        stopper.cancel()
    if task in done:
        return task.result()
    task.cancel()
    with contextlib.suppress(asyncio.CancelledError, Exception):
        await task
    raise StopBeforeFlight(f"{stop.signal_name} received")


@contextlib.asynccontextmanager
async def feeding(held: Held, cfg: HelixdConfig, notifier: ServiceNotifier) -> AsyncIterator[None]:
    """Keep our HEARTBEAT going during the setup phases (param reads, arming retries).

    The control loop feeds the heartbeat itself while flying; this feeder exists only
    before it, and is cancelled before the fly phase starts.
    """
    period_s = cfg.link.heartbeat_liveness_s / 3

    async def feeder() -> None:
        while True:
            if held.ap is not None:
                held.ap.feed()
                notifier.watchdog()
            await asyncio.sleep(period_s)

    task = asyncio.create_task(feeder(), name="setup-feeder")
    try:
        yield
    finally:
        await stop_task(task)


# -- connect ---------------------------------------------------------------------------------


async def start_sink(cfg: HelixdConfig, ap: Autopilot, held: Held) -> ActuatorSink:
    """The actuator sink, started (it sends neutral first), held for shutdown."""
    sink = make_sink(cfg.actuation, cfg.vehicle, ap)
    held.sink = sink
    await sink.start()
    return sink


async def reach(cfg: HelixdConfig, stop: StopRequest) -> Autopilot:
    """``helixd run``'s own link, made before anything is recorded: open the transport and
    wait for the autopilot's HEARTBEAT (``startup.connect_timeout_s``). The link closed and
    LinkError (one human message) when it cannot be made; nothing is sent but the udpout
    announce, and these first frames are not in the tlog (it opens with the run directory)."""
    ap = await Autopilot.connect(cfg.link, cfg.safety)
    try:
        await until_stopped(stop, ap.wait_heartbeat(cfg.startup.connect_timeout_s))
    except BaseException:
        with contextlib.suppress(Exception):
            await ap.close()
        raise
    return ap


async def connect(
    ap: Autopilot,
    cfg: HelixdConfig,
    held: Held,
    stop: StopRequest,
    on_link: Callable[[Autopilot], None],
    run_dir: Path | None,
) -> Autopilot:
    """``helixd run``'s own link, reached (:func:`reach`): record the tlog in ``run_dir``,
    wait for the autopilot's HEARTBEAT, start ours, neutral on the servo outputs, then the
    streams."""
    held.ap = ap
    on_link(ap)
    if run_dir is not None and cfg.link.tlog_enabled:
        attach_tlog(ap, run_dir / TLOG_FILE, cfg.link.tlog_max_bytes)
    await until_stopped(stop, ap.wait_heartbeat(cfg.startup.connect_timeout_s))
    ap.start_heartbeat()
    ap.feed()
    if cfg.actuation.backend is ActuationBackend.SERVO:
        # A previous run may have been killed with DO_SET_SERVO outputs latched: neutral
        # goes out before anything else.
        await start_sink(cfg, ap, held)
    await ap.request_streams()  # logs ``streams_granted`` itself
    return ap


def open_flight_tlog(ap: Autopilot, cfg: HelixdConfig, run_dir: Path | None) -> LinkTlog | None:
    """``helixd serve``'s flight: record the service's link in the flight's ``run_dir`` from now
    until :func:`close_flight_tlog` (None: no run directory, or ``link.tlog_enabled`` off).
    The service's link lives all day; each flight takes its traffic into its own tlog."""
    if run_dir is None or not cfg.link.tlog_enabled:
        return None
    return attach_tlog(ap, run_dir / TLOG_FILE, cfg.link.tlog_max_bytes)


def close_flight_tlog(ap: Autopilot, tlog: LinkTlog) -> None:
    """The flight is over: its tlog no longer records the link (unless another took its place)
    and is flushed and closed; the link stays up."""
    if ap.tlog is tlog:
        ap.attach_tlog(None)
    tlog.close()
    log.info("tlog_closed", path=str(tlog.writer.path), bytes=tlog.writer.written_bytes)


async def attach(
    ap: Autopilot,
    cfg: HelixdConfig,
    held: Held,
    stop: StopRequest,
    on_link: Callable[[Autopilot], None],
) -> Autopilot:
    """A link already up (``helixd serve``'s: heartbeating, streams negotiated): wait for the
    autopilot's HEARTBEAT, neutral on the servo outputs."""
    held.ap = ap
    on_link(ap)
    await until_stopped(stop, ap.wait_heartbeat(cfg.startup.connect_timeout_s))
    ap.feed()
    if cfg.actuation.backend is ActuationBackend.SERVO:
        await start_sink(cfg, ap, held)
    return ap


# -- preflight: the vehicle ------------------------------------------------------------------


def pose_invalid_too_long(ap: Autopilot, cfg: HelixdConfig) -> Fault | None:
    """Pose telemetry rejected for longer than the stale limit (as the watchdog)."""
    st = ap.state
    return pose_invalid_fault(
        now_s(),
        None if st.pose is None else st.pose.rx_monotonic_s,
        st.pose_invalid_since_s,
        st.pose_invalid_reason,
        cfg.safety.pose_stale_s,
        what="start pose",
    )


async def fresh_pose(ap: Autopilot, cfg: HelixdConfig, stop: StopRequest) -> NedPose | None:
    """A fresh, valid pose with a healthy EKF; None when there is none.

    Never an invalid one: the vehicle state stores only valid poses (checked against the
    configured ``safety.telemetry_*`` bounds), and while pose telemetry is being rejected
    the last stored pose is not taken; rejected for longer than the stale limit, this gives
    up at once (None) instead of waiting out the timeout.
    """
    safety = cfg.safety
    ap.state.bounds = TelemetryBounds.from_safety(safety)
    deadline = now_s() + cfg.startup.connect_timeout_s
    while now_s() < deadline:
        ap.feed()
        poll_s = min(0.2, safety.pose_stale_s / 4)  # notice invalid poses early
        sample = await until_stopped(
            stop, ap.telemetry.next_pose(after_rx_s=None, timeout_s=poll_s)
        )
        if pose_invalid_too_long(ap, cfg) is not None:
            return None
        ekf = ap.state.ekf
        fresh = (
            sample is not None
            and not ap.state.pose_invalid
            and now_s() - sample.rx_monotonic_s <= safety.pose_stale_s
        )
        if sample is not None and fresh and ekf is not None and ekf.healthy:
            return sample.ned
    sample = ap.state.pose
    return None if sample is None or ap.state.pose_invalid else sample.ned


def gps_now(st: VehicleState, safety: SafetyConfig) -> Fault | None:
    """The GPS as the watchdog would judge it now (None: good enough to drive on)."""
    return gps_fault(
        now_s(), st.gps_rx_s, st.gps_fix_type, st.gps_satellites, safety, st.gps_fix_rx_s
    )


async def gps_verdict(st: VehicleState, telemetry: Telemetry, safety: SafetyConfig) -> Fault | None:
    """The GPS judged once it has had the chance to report: the pose can be fresh before the
    first GPS_RAW_INT with the same fix arrives (a slower stream), so a GPS not yet good is
    waited for up to ``safety.gps_stale_s``, the grace the watchdog gives it in flight."""
    await telemetry.wait_for(lambda s: gps_now(s, safety) is None, Change.GPS, safety.gps_stale_s)
    return gps_now(st, safety)


async def servo_output_problems(ap: Autopilot, cfg: HelixdConfig, mission: Mission) -> list[str]:
    """The mission's servo commands against the outputs' SERVOn_FUNCTION: ArduPilot
    refuses one on an output with another function ("Channel N is already in use"), and
    one on an output that passes a scroll's RC channel through (RC-override backend) would
    latch that scroll (``helixd check`` caught the same channel numbers already)."""
    out: list[str] = []
    scroll_rc = {c.channel: k for k, c in enumerate(cfg.actuation.channels)}
    rc_backend = cfg.actuation.backend is ActuationBackend.RC_OVERRIDE
    for n, wp in enumerate(mission.waypoints, start=1):
        if wp.command not in SERVO_COMMANDS:
            continue
        output = stored_whole(wp.param(0))
        function = await ap.param.get(f"SERVO{output}_FUNCTION")
        if function is None:
            out.append(f"item {n} {wp.name}: the autopilot has no output {output}")
            continue
        f = int(function)
        passthrough = passthrough_input(f)
        if rc_backend and passthrough in scroll_rc:
            k = scroll_rc[passthrough]
            out.append(
                f"item {n} {wp.name}: output {output} passes RC{passthrough} through "
                f"(SERVO{output}_FUNCTION = {f}), which drives scroll {k + 1}: a latched "
                "servo command would hold that scroll"
            )
        elif f not in DO_SET_SERVO_FUNCTIONS:
            out.append(
                f"item {n} {wp.name}: the autopilot refuses it on output {output} "
                f"(SERVO{output}_FUNCTION = {f}: 'ServoRelayEvent: Channel {output} is "
                "already in use'); give the output function 0"
            )
    return out


async def preflight(
    ap: Autopilot,
    cfg: HelixdConfig,
    mission: Mission,
    stop: StopRequest,
    on_warning: Callable[[str], None],
) -> Vehicle:
    """The vehicle obeys, its servo outputs take the mission's servo commands, a fresh pose
    with a healthy EKF, the EKF origin (a global mission needs it); every problem at once
    (:class:`PreflightFailed`); warnings go to ``on_warning`` as found."""
    problems: list[str] = []
    for p in await check_obedience(
        ap, cfg.actuation, cfg.link, cfg.safety.servo_guard, cfg.safety.stop_on_rc_loss
    ):
        if p.severity == "error":
            problems.append(p.message)
        else:
            log.warning("preflight_warning", message=p.message)
            on_warning(p.message)
    gate = cfg.startup.start_switch_channel
    if gate is not None:
        mode_ch = await ap.param.get("MODE_CH")
        if mode_ch is not None and int(mode_ch) == gate:
            problems.append(
                f"startup.start_switch_channel = {gate} is the autopilot's flight-mode channel "
                f"(MODE_CH = {int(mode_ch)}): flipping it would change the mode; use another "
                "channel"
            )
    problems += await servo_output_problems(ap, cfg, mission)
    pose = await fresh_pose(ap, cfg, stop)
    invalid = pose_invalid_too_long(ap, cfg)
    if pose is None and invalid is not None:
        problems.append(f"pose telemetry rejected: {invalid.detail}")
    elif pose is None:
        problems.append(
            f"no fresh pose (LOCAL_POSITION_NED + ATTITUDE) within "
            f"{cfg.startup.connect_timeout_s} s: check the EKF has an origin and GPS"
        )
    ekf = ap.state.ekf
    if ekf is None or not ekf.healthy:
        problems.append(
            "EKF not healthy: " + ("no EKF_STATUS_REPORT" if ekf is None else ekf.describe())
        )
    gps = await gps_verdict(ap.state, ap.telemetry, cfg.safety)
    if gps is not None:
        problems.append(
            f"GPS not good enough to drive on: {gps.detail} (safety.gps_min_fix_type, "
            "safety.gps_min_satellites)"
        )
    # the EKF origin: a global mission needs it; every run records it (export, plots)
    needed = mission.frame is MissionFrameKind.GLOBAL
    timeout_s = cfg.link.command_timeout_s * (3 if needed else 1)
    origin = await ap.action.request_gps_origin(timeout_s)
    if origin is None and needed:
        problems.append("global mission needs GPS_GLOBAL_ORIGIN; the autopilot sent none")
    if problems or pose is None:
        raise PreflightFailed(problems)
    return Vehicle(pose, origin)


# -- preflight: the mission from where the rover is ------------------------------------------


async def autopilot_home(
    ap: Autopilot,
    cfg: HelixdConfig,
    mission: Mission,
    origin: tuple[float, float] | None,
    stop: StopRequest,
) -> HomePosition | None:
    """The autopilot's home, for a mission with commands (NAV_RETURN_TO_LAUNCH)."""
    if not mission.has_commands():
        return None
    home = await until_stopped(stop, ap.action.request_home(cfg.link.command_timeout_s * 3))
    if home is not None:
        log.info(
            "home_position",
            lat_deg=round(home.lat_deg, 7),
            lon_deg=round(home.lon_deg, 7),
            north_m=None if home.north_m is None else round(home.north_m, 2),
            east_m=None if home.east_m is None else round(home.east_m, 2),
        )
        if home.north_m is None and origin is not None:  # sent without north/east
            n, e = latlon_to_ne(home.lat_deg, home.lon_deg, *origin)
            home = HomePosition(home.lat_deg, home.lon_deg, n, e)
    return home


def mission_frame(mission: Mission, start: NedPose) -> MissionFrame:
    """The frame the plan is flown in: a ``start`` mission's starts at the rover."""
    if mission.frame is MissionFrameKind.START:
        return MissionFrame.start_at(start)
    return MissionFrame.enu()


def resolve_flight(
    mission: Mission,
    cfg: HelixdConfig,
    origin: tuple[float, float] | None,
    start: NedPose,
    home: HomePosition | None,
    options: ExpandOptions,
    inputs: RunInputs | None = None,
) -> tuple[Plan, Where]:
    """The plan, and for a mission with commands its program from where the rover is
    (``start``) and the autopilot's home; what the program cannot fly is refused."""
    frame = mission_frame(mission, start)
    where = Where()
    if mission.has_commands():
        here = frame.to_mission(start)
        home_xy = None
        if home is not None and home.north_m is not None and home.east_m is not None:
            at = frame.to_mission(NedPose(home.north_m, home.east_m, 0.0))
            home_xy = (at.x_m, at.y_m)
        where = Where(start_xy_m=(here.x_m, here.y_m), home_xy_m=home_xy)
    resolved = resolve(
        mission, cfg.control, cfg.mission, origin, where, options,
        cfg.safety.mission_time_limit_s,
    )  # fmt: skip
    if resolved.problems:
        raise PreflightFailed(list(resolved.problems))
    program = resolved.plan.program
    returns = program is not None and any(
        s.command == MAV_CMD_NAV_RETURN_TO_LAUNCH for s in program.steps
    )
    if returns and where.home_xy_m is None:
        raise PreflightFailed(
            [
                "the mission returns home (NAV_RETURN_TO_LAUNCH) but the autopilot sent no "
                "home position (HOME_POSITION): wait for its GPS home and try again"
            ]
        )
    for note in resolved.notes:
        log.info("mission_note", note=note)
    return follow_medium(resolved.plan, mission, cfg, origin, start, inputs), where


def follow_medium(
    plan: Plan, mission: Mission, cfg: HelixdConfig, origin: tuple[float, float] | None,
    start: NedPose, inputs: RunInputs | None = None,
) -> Plan:  # fmt: skip
    """``plan`` with each stretch in its medium's mode when the flight has a media map
    (``inputs``: a resume's, to number the changes of mode as the whole mission)."""
    try:
        got = placed_media_plan(cfg, mission, plan, origin, start)
    except MediaRefused as exc:
        raise PreflightFailed(exc.problems) from None
    if got is None:
        return plan
    flown = got.plan
    vias = [w.via for w in flown.waypoints]
    numbering = program_numbering(flown) if flown.program is not None else None
    if numbering is None:
        numbering = Numbering.of(vias) if inputs is None else inputs.numbering(vias)
    for t in got.transitions:
        wp = flown.waypoints[t.index]
        log.info(
            "media_transition",
            # numbered as the operator numbers waypoints ("via → 2/9" at an inserted stop)
            waypoint=numbering.label(t.index), stop="media" if wp.media_stop else "waypoint",
            before=t.before.value, after=t.after.value,
            x_m=round(t.xy_m[0], 2), y_m=round(t.xy_m[1], 2), medium=t.medium.value,
        )  # fmt: skip
    where = media_path(cfg, mission)
    log.info(
        "media_plan", stretches=len(got.stretches), transitions=len(got.transitions),
        # what `helixd plot` draws the map's areas from, placed as the flight placed them
        media_map=None if where is None else str(where.resolve()), frame=plan.frame.value,
        start_north_m=round(start.north_m, 3), start_east_m=round(start.east_m, 3),
        start_yaw_ned_rad=round(start.yaw_ned_rad, 4),
    )  # fmt: skip
    return got.plan


async def place_mission(
    ap: Autopilot,
    cfg: HelixdConfig,
    mission: Mission,
    vehicle: Vehicle,
    stop: StopRequest,
    *,
    replan_from: Replanner | None = None,
    inputs: RunInputs | None = None,
    options: ExpandOptions,
) -> Checked:
    """The mission placed from the rover's pose and the EKF origin: its first leg re-planned
    from the rover (a route planned around obstacles), its plan (from the autopilot's home
    for a mission with commands; a resume re-enters the interrupted leg), and the checks
    ``helixd check`` ran, now with the start pose and the EKF origin (geofence radius and
    polygon, distance to the first waypoint, time)."""
    pose, origin = vehicle.pose, vehicle.origin
    if replan_from is not None:  # planned legs: the first from the rover
        try:
            mission = replan_from((pose.north_m, pose.east_m), origin)
        except ValueError as exc:
            raise PreflightFailed(str(exc).splitlines()) from None
    home = await autopilot_home(ap, cfg, mission, origin, stop)
    plan, where = resolve_flight(mission, cfg, origin, pose, home, options, inputs)
    if inputs is not None:  # a resume re-enters the interrupted leg
        plan = with_leg_start(plan, mission, inputs.leg_start, cfg.control, cfg.mission, origin)
    judged = judge_flight(
        mission, cfg, start_ned=pose, origin_latlon_deg=origin, options=options, where=where
    )
    if judged.problems:
        raise PreflightFailed(judged.problems)
    return Checked(pose, origin, plan, mission, judged.cfg, home)


async def show_checked_plan(
    ap: Autopilot, cfg: HelixdConfig, checked: Checked, stop: StopRequest
) -> str | None:
    """Upload the resolved plan for the GCS to draw (never flown: helixd.runtime.show_plan);
    a warning when it could not."""
    timeout_s = cfg.link.command_timeout_s * 3
    return await until_stopped(
        stop, show_plan(ap, checked.plan, checked.start_ned, checked.origin, timeout_s)
    )


# -- the start gate, home, arm ---------------------------------------------------------------


async def start_gate(
    ap: Autopilot, cfg: HelixdConfig, stop: StopRequest, notifier: ServiceNotifier
) -> None:
    """Wait for the pilot's start switch (``startup.start_switch_channel``), if there is one."""
    ch = cfg.startup.start_switch_channel
    if ch is None:
        return
    threshold = cfg.startup.start_switch_threshold_us
    log.info("waiting_for_start_switch", channel=ch, threshold_us=threshold)
    notifier.status(f"waiting for the pilot: RC{ch} >= {threshold} us")
    deadline = now_s() + cfg.startup.start_gate_timeout_s
    while now_s() < deadline:
        ap.feed()
        notifier.watchdog()
        rc = ap.state.rc_inputs_us
        if len(rc) >= ch and rc[ch - 1] >= threshold:
            log.info("start_switch_on", channel=ch, pwm_us=rc[ch - 1])
            return
        await until_stopped(stop, ap.telemetry.next_pose(after_rx_s=None, timeout_s=0.2))
    raise PreflightFailed(
        [f"start switch RC{ch} not flipped within {cfg.startup.start_gate_timeout_s} s"]
    )


async def wait_home(
    ap: Autopilot, cfg: HelixdConfig, on_status: Callable[[str], None]
) -> str | None:
    """Wait for the autopilot's home before arming, instead of forcing the arm; returns a
    warning when arming is forced without one.

    ArduPilot Rover sets home from the EKF's first position (``Rover::ahrs_update``),
    sends HOME_POSITION when it does, and until then refuses to arm ("PreArm: AHRS:
    waiting for home"). HOME_POSITION is asked for every ``startup.arm_retry_interval_s``
    (ArduPilot answers only once home is set) for at most ``startup.home_timeout_s``; then
    the run is refused (exit 3, nothing armed), or with ``startup.force_arm`` armed anyway.
    """
    startup = cfg.startup
    deadline = now_s() + startup.home_timeout_s
    waiting = False
    while ap.state.home is None:
        remaining = deadline - now_s()
        if remaining <= 0.0:
            text = (
                f"the autopilot reported no home (HOME_POSITION) within "
                f"startup.home_timeout_s = {startup.home_timeout_s:g} s; ArduPilot arms only "
                "once its EKF has a position (GPS fix, EKF origin)"
            )
            if not startup.force_arm:
                raise PreflightFailed([text])
            log.warning("home_unknown_forcing", problem=text)
            return f"{text}; arming forced (startup.force_arm)"
        if not waiting:
            waiting = True
            log.info("waiting_for_home", timeout_s=startup.home_timeout_s)
            on_status("arm (waiting for the autopilot's home)")
        try:
            await ap.action.command_long(MAV_CMD_REQUEST_MESSAGE, (MAVLINK_MSG_ID_HOME_POSITION,))
        except CommandError as exc:  # it also sends HOME_POSITION by itself once set
            log.info("home_request_failed", error=str(exc))
        await ap.telemetry.wait_for(
            lambda st: st.home is not None,
            Change.HOME,
            min(remaining, startup.arm_retry_interval_s),
        )
    home = ap.state.home
    if home is not None:
        log.info(
            "home_known",
            lat_deg=round(home.lat_deg, 7),
            lon_deg=round(home.lon_deg, 7),
            waited=waiting,
        )
    return None


async def explain_arm_refusal(ap: Autopilot, exc: CommandRejected) -> CommandRejected:
    """An "Arm: Throttle (RCn) is not neutral" refusal names what RCn must read (its
    RCn_TRIM ± RCn_DZ, read now) and what it reads; any other refusal as it came."""
    channel = not_neutral_channel(exc.statustext)
    if channel is None:
        return exc
    trim, dz = await asyncio.gather(
        ap.param.get(f"RC{channel}_TRIM"), ap.param.get(f"RC{channel}_DZ")
    )
    reading = rc_reading(ap.state.rc_inputs_us, channel)
    hint = throttle_must_read(channel, trim, dz, reading)
    return CommandRejected(exc.command_name, exc.result, exc.statustext, hint)


async def arm(
    ap: Autopilot, cfg: HelixdConfig, held: Held, on_status: Callable[[str], None]
) -> str | None:
    """Arm once the autopilot has a home, re-trying while PreArm checks refuse; returns the
    warning of an arm forced without a home."""
    if ap.state.armed_now:
        return None
    warning = await wait_home(ap, cfg, on_status)
    startup = cfg.startup
    deadline = now_s() + startup.arm_timeout_s
    while True:
        try:
            await ap.action.arm(force=startup.force_arm)
            held.armed_by_us = True
            await confirm_armed(ap, cfg)
            return warning
        except CommandRejected as refused:
            exc = await explain_arm_refusal(ap, refused)
            if now_s() + startup.arm_retry_interval_s > deadline:
                raise exc from None
            log.warning(
                "arm_refused_retrying", reason=str(exc), retry_in_s=startup.arm_retry_interval_s
            )
            on_status(f"arm (autopilot says: {exc.statustext or exc.result_name})")
            await asyncio.sleep(startup.arm_retry_interval_s)


async def confirm_mode(ap: Autopilot, cfg: HelixdConfig, mode: str) -> None:
    """The ACK says 'accepted'; the HEARTBEAT's mode says it happened. Without this wait
    a vehicle still armed in HOLD (left by a faulted run) would show its last HOLD
    heartbeat to the flight loop, which reads it as a pilot takeover."""
    await heartbeat_shows(
        ap,
        cfg,
        lambda st: st.mode == mode,
        lambda st: f"mode {mode} was accepted but HEARTBEAT still shows {st.mode}",
    )


async def confirm_armed(ap: Autopilot, cfg: HelixdConfig) -> None:
    """The ACK says 'accepted'; the HEARTBEAT's armed flag says it happened."""
    await heartbeat_shows(
        ap,
        cfg,
        lambda st: st.armed_now,
        lambda _: "arming was accepted but HEARTBEAT never showed armed",
    )


async def heartbeat_shows(
    ap: Autopilot,
    cfg: HelixdConfig,
    holds: Callable[[VehicleState], bool],
    refusal: Callable[[VehicleState], str],
) -> None:
    """Until a HEARTBEAT shows what was just acknowledged, asked for every
    :data:`HEARTBEAT_ASK_S` (the autopilot's own come at 1 Hz: a start would wait up to a
    second for one); PreflightFailed with ``refusal`` after two HEARTBEAT timeouts."""
    deadline = now_s() + cfg.safety.heartbeat_timeout_s * 2
    asked_s = -math.inf
    while not holds(ap.state):
        now = now_s()
        if now > deadline:
            raise PreflightFailed([refusal(ap.state)])
        if now - asked_s >= HEARTBEAT_ASK_S:
            ap.request_heartbeat()
            asked_s = now
        await ap.telemetry.next_pose(after_rx_s=None, timeout_s=0.05)


def start_pose(
    checked: Checked,
    now: NedPose | None,
    ap: Autopilot,
    cfg: HelixdConfig,
    options: ExpandOptions,
) -> Checked:
    """The mission frame starts where the rover is now, after the pilot's start switch: the
    flight checked again from there (its start pose and the config in force from it); never
    from an invalid pose: armed with pose telemetry rejected is a fault
    (:class:`StartRefused`)."""
    invalid = pose_invalid_too_long(ap, cfg)
    if now is None and invalid is not None:
        raise StartRefused(invalid, now_s())
    if now is not None and now != checked.start_ned:
        # The rover may have been moved while the start gate waited: check again from here.
        moved = judge_flight(
            checked.mission,
            cfg,
            start_ned=now,
            origin_latlon_deg=checked.origin,
            options=options,
        )
        if moved.problems:
            why = "from the pose at arming: " + "; ".join(moved.problems)
            raise StartRefused(Fault(FaultCause.PREFLIGHT, why), now_s())
        return replace(checked, start_ned=now, cfg=moved.cfg)
    return checked


__all__ = [
    "Checked",
    "Held",
    "PreflightFailed",
    "StartRefused",
    "StopBeforeFlight",
    "Vehicle",
    "arm",
    "attach",
    "autopilot_home",
    "confirm_armed",
    "confirm_mode",
    "connect",
    "feeding",
    "fresh_pose",
    "mission_frame",
    "place_mission",
    "pose_invalid_too_long",
    "preflight",
    "resolve_flight",
    "servo_output_problems",
    "show_checked_plan",
    "start_gate",
    "start_pose",
    "start_sink",
    "until_stopped",
    "wait_home",
]


async def judge_autopilot_fence(
    ap: Autopilot, checked: Checked, warn: Callable[[str | None], None]
) -> None:
    """The route from the rover through every waypoint against the autopilot's own fence
    (:mod:`helixd.runtime.autopilot_fence`): a route it would stop is refused (exit 3)."""
    frame = mission_frame(checked.mission, checked.start_ned)
    start = checked.start_ned
    points = [(start.north_m, start.east_m)]
    labels = ["the start"]
    n = 0
    for w in checked.plan.waypoints:
        points.append(frame.to_ned(w.x_m, w.y_m))
        if w.via:
            labels.append(f"the via point → {n + 1}")
        else:
            n += 1
            labels.append(f"waypoint {n}")
    problems, warnings = await autopilot_fence_check(ap, checked.origin, points, labels)
    for warning in warnings:
        warn(warning)
    if problems:
        raise PreflightFailed(problems)
