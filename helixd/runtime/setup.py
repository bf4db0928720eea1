"""The setup phases of a flight up to the vehicle checked, as functions over the link and the
config: connect, preflight (the vehicle, its servo outputs, a fresh pose, the EKF origin), and
what every phase shares (the :class:`Held` ledger, :func:`until_stopped`, the refusals). The
mission placed from the rover's pose is :mod:`helixd.runtime.placing`; the start gate, arming
and the confirmations :mod:`helixd.runtime.arming`. :class:`helixd.runtime.daemon.MissionRunner`
calls them in order; each returns what it found or raises.

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
from collections.abc import AsyncIterator, Awaitable, Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

import structlog

from helixd.actuators.base import ActuatorSink
from helixd.actuators.factory import make_sink
from helixd.base.clock import now_s
from helixd.base.frames import NedPose
from helixd.base.plan import MissionFrameKind, Plan
from helixd.base.problems import Problems
from helixd.base.run_files import TLOG_FILE
from helixd.base.tasks import stop_task
from helixd.config.root import HelixdConfig
from helixd.config.safety import SafetyConfig
from helixd.config.vehicle import ActuationBackend
from helixd.link.connection import Autopilot
from helixd.link.services.preflight import check_obedience
from helixd.link.telemetry import Telemetry
from helixd.link.vehicle import Change, HomePosition, TelemetryBounds, VehicleState
from helixd.link.wire.tlog import LinkTlog, attach_tlog
from helixd.mav.servo_functions import DO_SET_SERVO_FUNCTIONS, passthrough_input
from helixd.mission.commands import SERVO_COMMANDS, stored_whole
from helixd.mission.model import Mission
from helixd.report.notify import ServiceNotifier
from helixd.runtime.signals import StopRequest
from helixd.safety.watchdogs import Fault, gps_fault, pose_invalid_fault

log = structlog.get_logger(__name__)
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


__all__ = [
    "Checked",
    "Held",
    "PreflightFailed",
    "StartRefused",
    "StopBeforeFlight",
    "Vehicle",
    "attach",
    "connect",
    "feeding",
    "fresh_pose",
    "pose_invalid_too_long",
    "preflight",
    "servo_output_problems",
    "start_sink",
    "until_stopped",
]
