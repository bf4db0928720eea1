"""``helixd run``: three explicit phases, startup → main_loop → shutdown.

* :meth:`MissionRunner.startup` — connect → preflight → start gate → set MANUAL → arm; returns
  a :class:`Ready` (the link, the sink, the plan, the mission frame, the start pose);
* :meth:`MissionRunner.main_loop` — fly; returns an :class:`Ending`;
* :meth:`MissionRunner.shutdown` — always: scrolls to neutral, every override released, HOLD
  requested (:func:`helixd.safety.supervisor.fall_back`), then the sink and the link closed,
  each bounded in time like the fall-back.

Each sub-phase is logged with its duration (``phase_start`` / ``phase_end``). What startup has
taken hold of so far (link, sink, "we armed it") is kept in a :class:`Held` ledger that shutdown
gives back, whatever stopped startup half way.

An exception ends the run through one table (:data:`EXIT_RULES`): it maps the exception *and
the stage it came from* to a fault cause and an exit code. A command refused during setup is
exit 3 ("nothing was armed"); the same refusal in flight (a DO_SET_SERVO refused mid-mission)
is a fault, exit 4, after the fall-back. Exit codes: :class:`helixd.base.exitcodes.ExitCode`.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from enum import StrEnum
from pathlib import Path
from typing import TypeVar

import structlog

from helixd import __version__
from helixd.actuators.base import ActuatorError, ActuatorSink
from helixd.actuators.factory import make_sink
from helixd.base.exitcodes import ExitCode
from helixd.base.frames import MissionFrame, NedPose, latlon_to_ne
from helixd.base.plan import MissionFrameKind, Numbering, Plan, mission_item_of
from helixd.base.run_files import TLOG_FILE
from helixd.config import ActuationBackend, HelixdConfig, config_to_yaml
from helixd.control.sequencer import SequencerEvent
from helixd.link.command_client import CommandError, CommandRejected
from helixd.link.connection import Autopilot
from helixd.link.preflight import check_obedience
from helixd.link.tlog import attach_tlog
from helixd.link.vehicle import Change, HomePosition, TelemetryBounds
from helixd.mav.constants import (
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_REQUEST_MESSAGE,
    MAVLINK_MSG_ID_HOME_POSITION,
)
from helixd.mav.servo_functions import DO_SET_SERVO_FUNCTIONS, passthrough_input
from helixd.mav.url import LinkError
from helixd.mission.commands import SERVO_COMMANDS, command_name, stored_whole
from helixd.mission.expand import DEFAULT_OPTIONS, ExpandOptions
from helixd.mission.model import Mission
from helixd.mission.resolve import PlanError, Where, resolve
from helixd.mission.resume import RUN_RESUMED_EVENT, RunInputs, with_leg_start
from helixd.mission.validate import apply_mission_limits
from helixd.recorder.rows import FlightRow
from helixd.recorder.rundir import RecorderUnavailable, RunRecorder
from helixd.recorder.summary import RunSummary, SummaryBuilder
from helixd.runtime.display import ProgressDisplay, result_line
from helixd.runtime.flight import (
    MANUAL_MODE,
    FlightLoop,
    FlightResult,
    PoseRejectedReport,
    StepReport,
)
from helixd.runtime.flight_report import StepJournal, rejected_progress, step_progress
from helixd.runtime.gcs_feed import GcsFeed, report_fallback
from helixd.runtime.mission_commands import MissionCommands
from helixd.runtime.notify import ServiceNotifier
from helixd.runtime.show_plan import show_plan
from helixd.runtime.signals import StopRequest, install, uninstall
from helixd.runtime.timing import flight_problems, plan_time_estimate
from helixd.safety.supervisor import fall_back
from helixd.safety.watchdogs import OPERATOR_CAUSES, Fault, FaultCause, pose_invalid_fault

log = structlog.get_logger(__name__)
T = TypeVar("T")


class PreflightFailed(Exception):
    def __init__(self, problems: list[str]) -> None:
        self.problems = problems
        super().__init__("; ".join(problems))


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
class RunOptions:
    cfg: HelixdConfig
    mission: Mission
    mission_yaml: str
    connect_url: str
    run_root: Path
    tty: bool
    # planning: the mission with its first leg re-planned from the rover's (north_m, east_m)
    # (and the EKF origin's (lat, lon), for a global mission)
    replan_from: Callable[[tuple[float, float], tuple[float, float] | None], Mission] | None = None
    show_plan: bool = (
        False  # upload the resolved plan for the GCS to draw (helixd.runtime.show_plan)
    )
    # inputs.json (mission/config hashes, resume link); None: no record (not resumable)
    inputs: RunInputs | None = None
    options: ExpandOptions = DEFAULT_OPTIONS  # --strict / --skip-unsupported (commands)
    # helixd serve: the service's link (connected, heartbeating, streams negotiated; the run
    # neither connects nor closes it), its stop request (the service owns the signals and
    # pauses through it), no start gate (the service started the flight on the operator's
    # word), and the mission item being flown, each time it changes (the GCS's current item)
    link: Autopilot | None = None
    stop: StopRequest | None = None
    start_gate: bool = True
    on_item: Callable[[int], None] | None = None
    notifier: ServiceNotifier | None = None  # None: the run's own (helixd run under systemd)


@dataclass
class RunOutcome:
    exit_code: ExitCode
    summary: RunSummary | None
    run_dir: Path | None
    messages: list[str] = field(default_factory=list)


@dataclass
class PhaseEnd:
    """How a phase that raised nothing ended: the fly phase returns its fault (a watchdog, a
    pilot's takeover, a stop signal) instead of raising it, and says so here."""

    ok: bool = True
    cause: str | None = None

    def failed(self, cause: str) -> None:
        self.ok, self.cause = False, cause


@contextlib.asynccontextmanager
async def phase(
    name: str, notifier: ServiceNotifier, display: ProgressDisplay
) -> AsyncIterator[PhaseEnd]:
    """Log a phase's start and end with its duration; tell systemd and the operator.

    ``phase_start`` is the one log event for entering a phase (the display only redraws);
    ``phase_end`` says ``ok=false`` when the phase raised or marked its :class:`PhaseEnd`
    failed (with the cause).
    """
    t0 = time.monotonic()
    log.info("phase_start", phase=name)
    notifier.status(f"phase: {name}")
    display.phase(name)
    end = PhaseEnd()
    try:
        yield end
    except BaseException:
        log.info("phase_end", phase=name, ok=False, duration_wall_s=round(time.monotonic() - t0, 3))
        raise
    cause = {} if end.cause is None else {"cause": end.cause}
    log.info(
        "phase_end", phase=name, ok=end.ok, **cause, duration_wall_s=round(time.monotonic() - t0, 3)
    )


class Stage(StrEnum):
    """Where an exception came from: the same error means different things before and after
    the rover was armed and driven."""

    SETUP = "setup"  # startup: connect, preflight, start gate, MANUAL, arm
    FLIGHT = "flight"  # main_loop: the scrolls are (or may be) driven


@dataclass(frozen=True)
class ExitRule:
    """One row of :data:`EXIT_RULES`."""

    exceptions: tuple[type[BaseException], ...]
    stage: Stage | None  # None: either stage
    cause: FaultCause | None  # None: the exception carries its own fault (StartRefused)
    code: ExitCode
    event: str | None  # the log event naming each problem (None: the fall-back's log says it)
    message_prefix: str | None  # the operator's message line ("preflight: …"); None: none


# First match wins. Setup failures happen before anything was driven (the fall-back still
# runs if the sink was started or we armed); flight failures are faults of a moving rover.
EXIT_RULES: tuple[ExitRule, ...] = (
    ExitRule((StopBeforeFlight,), None, FaultCause.SIGNAL, ExitCode.OPERATOR_STOP, None, None),
    ExitRule((StartRefused,), None, None, ExitCode.FAULT, None, None),
    ExitRule(
        (PreflightFailed, PlanError, CommandError),
        Stage.SETUP,
        FaultCause.PREFLIGHT,
        ExitCode.PREFLIGHT,
        "preflight_failed",
        "preflight",
    ),
    ExitRule((LinkError,), Stage.SETUP, FaultCause.LINK_LOST, ExitCode.LINK, "link_failed", "link"),
    ExitRule(
        (ActuatorError, CommandError),
        Stage.FLIGHT,
        FaultCause.ACTUATOR,
        ExitCode.FAULT,
        "flight_command_failed",
        None,
    ),
    ExitRule((LinkError,), Stage.FLIGHT, FaultCause.LINK_LOST, ExitCode.FAULT, "link_failed", None),
    ExitRule((Exception,), None, FaultCause.EXCEPTION, ExitCode.INTERNAL_ERROR, None, None),
)


def exit_rule(exc: BaseException, stage: Stage) -> ExitRule:
    """The first rule of :data:`EXIT_RULES` matching ``exc`` raised in ``stage``."""
    for rule in EXIT_RULES:
        if isinstance(exc, rule.exceptions) and rule.stage in (None, stage):
            return rule
    return EXIT_RULES[-1]


def problems_of(exc: BaseException) -> list[str]:
    """The human lines an exception stands for (a failed preflight has several)."""
    return list(exc.problems) if isinstance(exc, PreflightFailed) else [str(exc)]


@dataclass(frozen=True)
class Ending:
    """How the run ended: what shutdown and the summary need."""

    fault: Fault | None
    code: ExitCode
    detected_s: float | None = None  # monotonic time the fault was detected
    last_pose: NedPose | None = None


def ending_for(exc: BaseException, stage: Stage, now_s: float) -> tuple[Ending, ExitRule]:
    """Map an exception to the run's ending through :data:`EXIT_RULES` (pure)."""
    rule = exit_rule(exc, stage)
    if isinstance(exc, StartRefused):
        return Ending(exc.fault, rule.code, exc.detected_s), rule
    cause = rule.cause or FaultCause.EXCEPTION
    detail = (
        f"{type(exc).__name__}: {exc}"
        if cause is FaultCause.EXCEPTION
        else "; ".join(problems_of(exc))
    )
    detected = now_s if stage is Stage.FLIGHT else None
    return Ending(Fault(cause, detail), rule.code, detected), rule


def ending_of_flight(result: FlightResult) -> Ending:
    """The ending of a flight the loop itself ended (mission done, a watchdog, a signal)."""
    fault = result.fault
    if fault is None:
        code = ExitCode.OK
    elif fault.cause in OPERATOR_CAUSES:
        code = ExitCode.OPERATOR_STOP
    else:
        code = ExitCode.FAULT
    return Ending(fault, code, result.detected_s, result.last_pose)


def disarm_after(armed_by_us: bool, ending: Ending) -> bool | None:
    """Whether the fall-back disarms (pure). What we armed is disarmed after a completed
    mission and after an operator's stop signal (Ctrl-C, SIGTERM: nobody drives it now, and
    an armed rover in HOLD is one switch away from moving). After a fault, a pilot's takeover
    (the pilot may be driving it) or on a vehicle we did not arm, ``safety.disarm_on_fault``
    decides (None)."""
    if not armed_by_us:
        return None
    if ending.code is ExitCode.OK:
        return True
    if ending.fault is not None and ending.fault.cause in (FaultCause.SIGNAL, FaultCause.PAUSED):
        return True
    return None


@dataclass
class Held:
    """What startup has taken hold of so far: what shutdown must give back.

    Filled as startup goes (a preflight can fail after the sink sent its first neutral), read
    by shutdown only, which copes with every field unset.
    """

    ap: Autopilot | None = None
    sink: ActuatorSink | None = None
    armed_by_us: bool = False


@dataclass(frozen=True)
class Ready:
    """What startup hands to the main loop."""

    ap: Autopilot
    sink: ActuatorSink
    plan: Plan
    frame: MissionFrame
    start_ned: NedPose
    cfg: HelixdConfig  # with the mission's own fence and time limit in place (exact now)


@dataclass(frozen=True)
class Checked:
    """What preflight found: the start pose and, for a global mission, the EKF origin."""

    start_ned: NedPose
    origin: tuple[float, float] | None
    plan: Plan
    home: HomePosition | None = None  # the autopilot's home (missions with commands)


class MissionRunner:
    """Owns one run: startup → main_loop → shutdown, and the run's outputs (recorder, summary,
    operator messages)."""

    def __init__(self, opts: RunOptions) -> None:
        self.opts = opts
        self.cfg = opts.cfg
        self.stop = opts.stop or StopRequest()
        self.notifier = opts.notifier or ServiceNotifier()
        self.display = ProgressDisplay(tty=opts.tty)
        self.recorder: RunRecorder | None = None
        self.summary = SummaryBuilder()
        self.messages: list[str] = []
        self.gcs = GcsFeed(
            self.cfg.gcs_report
        )  # what the ground station sees (helixd.runtime.gcs_feed)
        # the plan's via flags per waypoint (a program expands the mission: its waypoints
        # are the plan's, jumps repeated)
        self._plan_vias: tuple[bool, ...] | None = None
        self._where = Where()  # a program's start and home, as preflight resolved it
        self.flight_loop: FlightLoop | None = None  # while flying

    def holding_forever(self) -> bool:
        """Flying, and holding at a NAV_LOITER_UNLIM until the operator continues."""
        seq = None if self.flight_loop is None else self.flight_loop.sequencer
        return seq is not None and seq.holding_forever

    def release_hold(self) -> bool:
        """The operator continues a NAV_LOITER_UNLIM hold (``helixd serve``)."""
        seq = None if self.flight_loop is None else self.flight_loop.sequencer
        released = seq is not None and seq.release_hold()
        if released:
            log.info("hold_released", by="operator")
        return released

    # -- helpers ------------------------------------------------------------------------------

    async def _until_stopped(self, awaitable: Awaitable[T]) -> T:
        """Await ``awaitable`` unless a stop signal arrives first."""
        task = asyncio.ensure_future(awaitable)
        stopper = asyncio.ensure_future(self.stop.event.wait())
        try:
            done, _ = await asyncio.wait({task, stopper}, return_when=asyncio.FIRST_COMPLETED)
        finally:
            stopper.cancel()
        if task in done:
            return task.result()
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError, Exception):
            await task
        raise StopBeforeFlight(f"{self.stop.signal_name} received")

    def _pose_text(self, ned: NedPose | None) -> str:
        if ned is None:
            return "unknown"
        return (
            f"N {ned.north_m:.2f} m, E {ned.east_m:.2f} m, "
            f"yaw {math.degrees(ned.yaw_ned_rad) % 360:.0f}° (NED)"
        )

    # -- startup ------------------------------------------------------------------------------

    async def _connect(self, held: Held) -> Autopilot:
        if self.opts.link is not None:  # the service's link: already up
            ap = held.ap = self.opts.link
            self.gcs.start(ap.send_message)
            await self._until_stopped(ap.wait_heartbeat(self.cfg.safety.connect_timeout_s))
            ap.feed()
            if self.cfg.actuation.backend is ActuationBackend.SERVO:
                held.sink = make_sink(self.cfg.actuation, self.cfg.vehicle, ap)
                await held.sink.start()
            return ap
        ap = await Autopilot.connect(self.cfg.link, self.cfg.safety)
        held.ap = ap
        self.gcs.start(ap.send_message)
        run_dir = self.recorder.run_dir if self.recorder is not None else None
        if run_dir is not None and self.cfg.link.tlog_enabled:
            attach_tlog(ap, run_dir / TLOG_FILE, self.cfg.link.tlog_max_bytes)
        await self._until_stopped(ap.wait_heartbeat(self.cfg.safety.connect_timeout_s))
        ap.start_heartbeat()
        ap.feed()
        if self.cfg.actuation.backend is ActuationBackend.SERVO:
            # A previous run may have been killed with DO_SET_SERVO outputs latched: neutral
            # goes out before anything else.
            sink = make_sink(self.cfg.actuation, self.cfg.vehicle, ap)
            held.sink = sink
            await sink.start()
        await ap.request_streams()  # logs ``streams_granted`` itself
        return ap

    async def _preflight(self, ap: Autopilot) -> Checked:
        problems: list[str] = []
        cfg = self.cfg
        for p in await check_obedience(ap, cfg.actuation, cfg.link, cfg.safety.servo_guard):
            if p.severity == "error":
                problems.append(p.message)
            else:
                log.warning("preflight_warning", message=p.message)
                self.messages.append(f"warning: {p.message}")
        gate = self.cfg.safety.start_switch_channel
        if gate is not None:
            mode_ch = await ap.param.get("MODE_CH")
            if mode_ch is not None and int(mode_ch) == gate:
                problems.append(
                    f"safety.start_switch_channel = {gate} is the autopilot's flight-mode channel "
                    f"(MODE_CH = {int(mode_ch)}): flipping it would change the mode; use another "
                    "channel"
                )
        problems += await self._servo_outputs(ap)
        pose = await self._fresh_pose(ap)
        invalid = self._pose_invalid_too_long(ap)
        if pose is None and invalid is not None:
            problems.append(f"pose telemetry rejected: {invalid.detail}")
        elif pose is None:
            problems.append(
                f"no fresh pose (LOCAL_POSITION_NED + ATTITUDE) within "
                f"{self.cfg.safety.connect_timeout_s} s: check the EKF has an origin and GPS"
            )
        ekf = ap.state.ekf
        if ekf is None or not ekf.healthy:
            problems.append(
                "EKF not healthy: " + ("no EKF_STATUS_REPORT" if ekf is None else ekf.describe())
            )
        # the EKF origin: a global mission needs it; every run records it (export, plots)
        needed = self.opts.mission.frame is MissionFrameKind.GLOBAL
        timeout_s = self.cfg.link.command_timeout_s * (3 if needed else 1)
        origin = await ap.action.request_gps_origin(timeout_s)
        if origin is None and needed:
            problems.append("global mission needs GPS_GLOBAL_ORIGIN; the autopilot sent none")
        if problems or pose is None:
            raise PreflightFailed(problems)
        if self.opts.replan_from is not None:  # planned legs: the first from the rover
            try:
                here = (pose.north_m, pose.east_m)
                self.opts.mission = self.opts.replan_from(here, origin)
            except ValueError as exc:
                raise PreflightFailed(str(exc).splitlines()) from None
        home = await self._home(ap, origin)
        start_frame = self.opts.mission.frame is MissionFrameKind.START
        plan = self._resolve(
            origin, pose, home, MissionFrame.start_at(pose) if start_frame else MissionFrame.enu()
        )
        if self.opts.inputs is not None:  # a resume re-enters the interrupted leg
            plan = with_leg_start(
                plan,
                self.opts.mission,
                self.opts.inputs.leg_start,
                self.cfg.control,
                self.cfg.mission,
                origin,
            )
        # The same validation `helixd check` ran, now with the start pose and EKF origin
        # (geofence radius/polygon and time for local_ned/global missions).
        refused = flight_problems(
            self.opts.mission,
            self.cfg,
            start_ned=pose,
            origin_latlon_deg=origin,
            options=self.opts.options,
            where=self._where,
        )
        if refused:
            raise PreflightFailed(refused)
        last = plan.waypoints[-1]
        # a resume's approach to the interrupted leg is not the mission's cross-track error
        join_m = None if plan.leg_start_xy_m is None else self.cfg.control.stop_tolerance_m
        estimate = plan_time_estimate(plan, self.cfg, pose)  # what `check` says, from here
        log.info("flight_estimate", estimated_s=round(estimate.total_s, 1), pivots=estimate.pivots)
        self.summary = SummaryBuilder(
            final_xy_m=(last.x_m, last.y_m), join_m=join_m, estimated_s=estimate.total_s
        )
        self._plan_vias = tuple(w.via for w in plan.waypoints)
        if origin is not None:
            self.summary.set_origin(*origin)
        return Checked(pose, origin, plan, home)

    def _resolve(
        self,
        origin: tuple[float, float] | None,
        start: NedPose,
        home: HomePosition | None,
        frame: MissionFrame,
    ) -> Plan:
        """The plan, and for a mission with commands its program from where the rover is
        (``start``) and the autopilot's home; what the program cannot fly is refused."""
        msn = self.opts.mission
        where = Where()
        if msn.has_commands():
            here = frame.to_mission(start)
            home_xy = None
            if home is not None and home.north_m is not None and home.east_m is not None:
                home_ned = NedPose(home.north_m, home.east_m, 0.0)
                at = frame.to_mission(home_ned)
                home_xy = (at.x_m, at.y_m)
            where = Where(start_xy_m=(here.x_m, here.y_m), home_xy_m=home_xy)
        self._where = where
        resolved = resolve(
            msn, self.cfg.control, self.cfg.mission, origin, where, self.opts.options
        )
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
        return resolved.plan

    async def _servo_outputs(self, ap: Autopilot) -> list[str]:
        """The mission's servo commands against the outputs' SERVOn_FUNCTION: ArduPilot
        refuses one on an output with another function ("Channel N is already in use"), and
        one on an output that passes a scroll's RC channel through (RC-override backend) would
        latch that scroll (``helixd check`` caught the same channel numbers already)."""
        out: list[str] = []
        scroll_rc = {c.channel: k for k, c in enumerate(self.cfg.actuation.channels)}
        rc_backend = self.cfg.actuation.backend is ActuationBackend.RC_OVERRIDE
        for n, wp in enumerate(self.opts.mission.waypoints, start=1):
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

    async def _home(self, ap: Autopilot, origin: tuple[float, float] | None) -> HomePosition | None:
        """The autopilot's home, for a mission with commands (NAV_RETURN_TO_LAUNCH)."""
        if not self.opts.mission.has_commands():
            return None
        home = await self._until_stopped(
            ap.action.request_home(self.cfg.link.command_timeout_s * 3)
        )
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

    async def _show_plan(self, ap: Autopilot, checked: Checked) -> None:
        timeout_s = self.cfg.link.command_timeout_s * 3
        warning = await self._until_stopped(
            show_plan(ap, checked.plan, checked.start_ned, checked.origin, timeout_s)
        )
        if warning is not None:
            self.messages.append(f"warning: {warning}")

    def _pose_invalid_too_long(self, ap: Autopilot) -> Fault | None:
        """Pose telemetry rejected for longer than the stale limit (as the watchdog)."""
        st = ap.state
        return pose_invalid_fault(
            time.monotonic(),
            None if st.pose is None else st.pose.rx_monotonic_s,
            st.pose_invalid_since_s,
            st.pose_invalid_reason,
            self.cfg.safety.pose_stale_s,
            what="start pose",
        )

    async def _fresh_pose(self, ap: Autopilot) -> NedPose | None:
        """A fresh, valid pose with a healthy EKF; None when there is none.

        Never an invalid one: the vehicle state stores only valid poses (checked against the
        configured ``safety.telemetry_*`` bounds), and while pose telemetry is being rejected
        the last stored pose is not taken; rejected for longer than the stale limit, this gives
        up at once (None) instead of waiting out the timeout.
        """
        ap.state.bounds = TelemetryBounds.from_safety(self.cfg.safety)
        deadline = time.monotonic() + self.cfg.safety.connect_timeout_s
        while time.monotonic() < deadline:
            ap.feed()
            poll_s = min(0.2, self.cfg.safety.pose_stale_s / 4)  # notice invalid poses early
            sample = await self._until_stopped(
                ap.telemetry.next_pose(after_rx_s=None, timeout_s=poll_s)
            )
            if self._pose_invalid_too_long(ap) is not None:
                return None
            ekf = ap.state.ekf
            fresh = (
                sample is not None
                and not ap.state.pose_invalid
                and time.monotonic() - sample.rx_monotonic_s <= self.cfg.safety.pose_stale_s
            )
            if sample is not None and fresh and ekf is not None and ekf.healthy:
                return sample.ned
        sample = ap.state.pose
        return None if sample is None or ap.state.pose_invalid else sample.ned

    async def _start_gate(self, ap: Autopilot) -> None:
        ch = self.cfg.safety.start_switch_channel
        if ch is None:
            return
        threshold = self.cfg.safety.start_switch_threshold_us
        log.info("waiting_for_start_switch", channel=ch, threshold_us=threshold)
        self.notifier.status(f"waiting for the pilot: RC{ch} >= {threshold} us")
        deadline = time.monotonic() + self.cfg.safety.start_gate_timeout_s
        while time.monotonic() < deadline:
            ap.feed()
            self.notifier.watchdog()
            rc = ap.state.rc_inputs_us
            if len(rc) >= ch and rc[ch - 1] >= threshold:
                log.info("start_switch_on", channel=ch, pwm_us=rc[ch - 1])
                return
            await self._until_stopped(ap.telemetry.next_pose(after_rx_s=None, timeout_s=0.2))
        raise PreflightFailed(
            [f"start switch RC{ch} not flipped within {self.cfg.safety.start_gate_timeout_s} s"]
        )

    async def _wait_home(self, ap: Autopilot) -> None:
        """Wait for the autopilot's home before arming, instead of forcing the arm.

        ArduPilot Rover sets home from the EKF's first position (``Rover::ahrs_update``),
        sends HOME_POSITION when it does, and until then refuses to arm ("PreArm: AHRS:
        waiting for home"). HOME_POSITION is asked for every ``safety.arm_retry_interval_s``
        (ArduPilot answers only once home is set) for at most ``safety.home_timeout_s``; then
        the run is refused (exit 3, nothing armed), or with ``safety.force_arm`` armed anyway.
        """
        safety = self.cfg.safety
        deadline = time.monotonic() + safety.home_timeout_s
        waiting = False
        while ap.state.home is None:
            remaining = deadline - time.monotonic()
            if remaining <= 0.0:
                text = (
                    f"the autopilot reported no home (HOME_POSITION) within "
                    f"safety.home_timeout_s = {safety.home_timeout_s:g} s; ArduPilot arms only "
                    "once its EKF has a position (GPS fix, EKF origin)"
                )
                if not safety.force_arm:
                    raise PreflightFailed([text])
                log.warning("home_unknown_forcing", problem=text)
                self.messages.append(f"warning: {text}; arming forced (safety.force_arm)")
                return
            if not waiting:
                waiting = True
                log.info("waiting_for_home", timeout_s=safety.home_timeout_s)
                self.display.phase("arm (waiting for the autopilot's home)")
            try:
                await ap.action.command_long(
                    MAV_CMD_REQUEST_MESSAGE, (MAVLINK_MSG_ID_HOME_POSITION,)
                )
            except CommandError as exc:  # it also sends HOME_POSITION by itself once set
                log.info("home_request_failed", error=str(exc))
            await ap.telemetry.wait_for(
                lambda st: st.home is not None,
                Change.HOME,
                min(remaining, safety.arm_retry_interval_s),
            )
        if ap.state.home is not None:
            home = ap.state.home
            log.info(
                "home_known",
                lat_deg=round(home.lat_deg, 7),
                lon_deg=round(home.lon_deg, 7),
                waited=waiting,
            )

    async def _arm(self, ap: Autopilot, held: Held) -> None:
        """Arm once the autopilot has a home, re-trying while PreArm checks refuse."""
        if ap.state.armed:
            return
        await self._wait_home(ap)
        deadline = time.monotonic() + self.cfg.safety.arm_timeout_s
        while True:
            try:
                await ap.action.arm(force=self.cfg.safety.force_arm)
                held.armed_by_us = True
                await self._confirm_armed(ap)
                return
            except CommandRejected as exc:
                if time.monotonic() + self.cfg.safety.arm_retry_interval_s > deadline:
                    raise
                log.warning(
                    "arm_refused_retrying",
                    reason=str(exc),
                    retry_in_s=self.cfg.safety.arm_retry_interval_s,
                )
                self.display.phase(f"arm (autopilot says: {exc.statustext or exc.result_name})")
                await asyncio.sleep(self.cfg.safety.arm_retry_interval_s)

    async def _confirm_mode(self, ap: Autopilot, mode: str) -> None:
        """The ACK says 'accepted'; the HEARTBEAT's mode says it happened. Without this wait
        a vehicle still armed in HOLD (left by a faulted run) would show its last HOLD
        heartbeat to the flight loop, which reads it as a pilot takeover."""
        deadline = time.monotonic() + self.cfg.safety.heartbeat_timeout_s * 2
        while ap.state.mode != mode:
            if time.monotonic() > deadline:
                raise PreflightFailed(
                    [f"mode {mode} was accepted but HEARTBEAT still shows {ap.state.mode}"]
                )
            await ap.telemetry.next_pose(after_rx_s=None, timeout_s=0.05)

    async def _confirm_armed(self, ap: Autopilot) -> None:
        """The ACK says 'accepted'; the HEARTBEAT's armed flag says it happened."""
        deadline = time.monotonic() + self.cfg.safety.heartbeat_timeout_s * 2
        while not ap.state.armed:
            if time.monotonic() > deadline:
                raise PreflightFailed(["arming was accepted but HEARTBEAT never showed armed"])
            await ap.telemetry.next_pose(after_rx_s=None, timeout_s=0.05)

    @contextlib.asynccontextmanager
    async def _feeding(self, held: Held) -> AsyncIterator[None]:
        """Keep our HEARTBEAT going during the setup phases (param reads, arming retries).

        The control loop feeds the heartbeat itself while flying; this feeder exists only
        before it, and is cancelled before the fly phase starts.
        """
        period_s = self.cfg.link.heartbeat_liveness_s / 3

        async def feeder() -> None:
            while True:
                if held.ap is not None:
                    held.ap.feed()
                    self.notifier.watchdog()
                await asyncio.sleep(period_s)

        task = asyncio.create_task(feeder(), name="setup-feeder")
        try:
            yield
        finally:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task

    async def startup(self, held: Held) -> Ready:
        """connect → preflight → start gate → MANUAL → arm. Returns what the flight needs."""
        async with self._feeding(held):
            async with phase("connect", self.notifier, self.display):
                ap = await self._connect(held)
            self.gcs.phase("preflight")
            async with phase("preflight", self.notifier, self.display):
                checked = await self._preflight(ap)
            if self.opts.show_plan:  # for the GCS to draw; never flown (helixd.runtime.show_plan)
                await self._show_plan(ap, checked)
            # READY once preflight passed: the start gate may wait minutes for the pilot, and
            # systemd's TimeoutStartSec must not kill that wait; the watchdog runs from here on.
            self.notifier.ready("preflight passed")
            if self.opts.start_gate:
                async with phase("start_gate", self.notifier, self.display):
                    await self._start_gate(ap)
            async with phase("set_manual", self.notifier, self.display):
                await self._until_stopped(ap.action.set_mode(MANUAL_MODE))
                await self._confirm_mode(ap, MANUAL_MODE)
            sink = held.sink
            if sink is None:
                sink = make_sink(self.cfg.actuation, self.cfg.vehicle, ap)
                held.sink = sink
                await sink.start()
            async with phase("arm", self.notifier, self.display):
                await self._until_stopped(self._arm(ap, held))
            self.gcs.phase("armed")
            start_ned = self._start_pose(checked, await self._fresh_pose(ap), ap)
        frame = (
            MissionFrame.start_at(start_ned)
            if checked.plan.frame is MissionFrameKind.START
            else MissionFrame.enu()
        )
        plan = checked.plan
        if self.opts.mission.has_commands():
            # from where the rover is now, to the home the autopilot set when it armed
            home = await self._home(ap, checked.origin) or checked.home
            plan = self._resolve(checked.origin, start_ned, home, frame)
        # the mission's own geofence/time limit, now placed exactly (origin and start known)
        cfg = apply_mission_limits(
            self.cfg, self.opts.mission, origin_latlon_deg=checked.origin, start_ned=start_ned
        )
        return Ready(ap, sink, plan, frame, start_ned, cfg)

    def _start_pose(self, checked: Checked, now: NedPose | None, ap: Autopilot) -> NedPose:
        """The mission frame starts where the rover is now, after the pilot's start switch;
        never from an invalid pose: armed with pose telemetry rejected is a fault."""
        invalid = self._pose_invalid_too_long(ap)
        if now is None and invalid is not None:
            raise StartRefused(invalid, time.monotonic())
        if now is not None and now != checked.start_ned:
            # The rover may have been moved while the start gate waited: check again from here.
            moved = flight_problems(
                self.opts.mission,
                self.cfg,
                start_ned=now,
                origin_latlon_deg=checked.origin,
                options=self.opts.options,
            )
            if moved:
                fault = Fault(FaultCause.PREFLIGHT, "from the pose at arming: " + "; ".join(moved))
                raise StartRefused(fault, time.monotonic())
        return now or checked.start_ned

    # -- main loop ----------------------------------------------------------------------------

    async def main_loop(self, ready: Ready) -> Ending:
        """Fly the plan; the loop returns its own ending (done, a watchdog, a signal)."""
        plan = ready.plan
        numbering = self._numbering()
        ap = ready.ap
        commands = MissionCommands(ap.action)
        if plan.program is not None:
            commands.start()

        def on_mission_event(ev: SequencerEvent) -> None:
            log.info(
                "mission_step",
                kind=ev.kind,
                item=ev.item,
                command=command_name(ev.command),
                step=ev.step + 1,
                text=ev.text,
            )
            if ev.kind == "hold_started":
                self.gcs.phase(f"item {ev.item}: {ev.text}")

        # flight.csv rows and the summary's figures are built in batches, after sends
        journal = StepJournal(plan, self._on_row, self.cfg.recorder.batch_interval_s)

        def on_step(report: StepReport) -> None:  # after the command left
            nav = report.step.nav
            self.gcs.progress(nav.cross_track_m, numbering.number(nav.target_index))
            journal.add(report)
            self.display.update(lambda: step_progress(report, numbering))  # if shown

        def on_pose_rejected(report: PoseRejectedReport) -> None:
            self.display.update(rejected_progress(report, numbering))

        on_item = self.opts.on_item

        def on_arrival(index: int, t_boot_s: float, error_m: float) -> None:
            journal.drain()  # the summary has every step before the arrival
            self._on_arrival(index, numbering, t_boot_s, error_m)
            if on_item is not None and index + 1 < len(plan.waypoints):
                on_item(mission_item_of(plan, numbering, index + 1))

        if on_item is not None:
            on_item(mission_item_of(plan, numbering, 0))

        def on_tick() -> None:
            ap.feed()
            self.notifier.watchdog()
            journal.maybe_drain(time.monotonic())
            if self.recorder is not None:
                self.recorder.maybe_flush()

        self.gcs.phase(f"fly {self.opts.mission.name}: {numbering.operator_count} waypoints")
        async with phase("fly", self.notifier, self.display) as fly:
            try:
                self.flight_loop = FlightLoop(
                    cfg=ready.cfg,
                    plan=ready.plan,
                    frame=ready.frame,
                    autopilot=ap,
                    sink=ready.sink,
                    stop=self.stop,
                    start_ned=ready.start_ned,
                    on_step=on_step,
                    on_pose_rejected=on_pose_rejected,
                    on_arrival=on_arrival,
                    on_tick=on_tick,
                    on_action=commands.submit,
                    on_mission_event=on_mission_event,
                )
                result = await self.flight_loop.run()
            finally:
                self.flight_loop = None
                journal.drain()  # every step reaches flight.csv and the summary
                # the payload commands already due still go out (bounded), before the stop
                await commands.close(self.cfg.safety.fallback_deadline_s)
            if result.fault is not None:  # e.g. Ctrl-C: an operator stop, not "ok"
                fly.failed(result.fault.cause.value)
        return ending_of_flight(result)

    # -- the run ------------------------------------------------------------------------------

    async def run(self) -> RunOutcome:
        loop = asyncio.get_running_loop()
        own_signals = self.opts.stop is None  # else the service owns them
        if own_signals:
            install(loop, self.stop)
        try:
            return await self._run()
        except Exception as exc:  # escaped the shutdown path itself: still end with a result
            log.exception("internal_error")
            fault = f"{FaultCause.EXCEPTION.value}: {type(exc).__name__}: {exc}"
            summary = self._build_summary(fault, ExitCode.INTERNAL_ERROR, None)
            run_dir = self.recorder.run_dir if self.recorder else None
            return RunOutcome(
                ExitCode.INTERNAL_ERROR, summary, run_dir, [*self.messages, result_line(summary)]
            )
        finally:
            if own_signals:
                uninstall(loop)
            self.display.close()

    async def _run(self) -> RunOutcome:
        try:
            self.recorder = RunRecorder.create(
                run_root=self.opts.run_root,
                mission_name=self.opts.mission.name,
                config_yaml=config_to_yaml(self.cfg),
                mission_yaml=self.opts.mission_yaml,
                cfg=self.cfg.recorder,
                now_utc=datetime.now(UTC),
                inputs_json=None if self.opts.inputs is None else self.opts.inputs.to_json(),
            )
        except RecorderUnavailable as exc:
            summary = self._build_summary(f"recorder: {exc}", ExitCode.PREFLIGHT, None)
            return RunOutcome(ExitCode.PREFLIGHT, None, None, [str(exc), result_line(summary)])
        log.info(
            "helixd_start",
            version=__version__,
            mission=self.opts.mission.name,
            connect=self.opts.connect_url,
            run_dir=str(self.recorder.run_dir),
        )
        resumed = None if self.opts.inputs is None else self.opts.inputs.resumed_from
        if resumed is not None and self.opts.inputs is not None:
            log.info(
                RUN_RESUMED_EVENT,
                resumed_from=resumed.path,
                resumed_mission_sha256=resumed.mission_sha256,
                first_waypoint=self._numbering().label(0),
            )
        started = time.monotonic()
        held = Held()
        ending = Ending(None, ExitCode.INTERNAL_ERROR)  # if cancelled before an ending is known
        try:
            ending = await self._startup_then_fly(held)
        finally:
            await self.shutdown(held, ending)
        summary = self._finish(ending, started)
        return RunOutcome(
            ending.code,
            summary,
            self.recorder.run_dir if self.recorder else None,
            [*self.messages, result_line(summary)],  # the plain result line comes last
        )

    async def _startup_then_fly(self, held: Held) -> Ending:
        stage = Stage.SETUP
        try:
            ready = await self.startup(held)
            stage = Stage.FLIGHT
            return await self.main_loop(ready)
        except Exception as exc:
            ending, rule = ending_for(exc, stage, time.monotonic())
            self._report_failure(exc, rule)
            return ending

    def _report_failure(self, exc: Exception, rule: ExitRule) -> None:
        """The log events and operator lines of an exception that ended the run."""
        if rule.cause is FaultCause.EXCEPTION:
            log.exception("internal_error")
            return
        problems = problems_of(exc)
        if rule.event is not None:
            for p in problems:
                log.error(rule.event, problem=p)
        if rule.message_prefix is not None:
            self.messages.extend(f"{rule.message_prefix}: {p}" for p in problems)

    # -- shutdown -----------------------------------------------------------------------------

    async def shutdown(self, held: Held, ending: Ending) -> None:
        """Always: stop the scrolls, release overrides, ask for HOLD (if we touched anything);
        then close the sink and the link, each bounded like the fall-back."""
        self.notifier.stopping()
        ap = held.ap
        touched = held.sink is not None or held.armed_by_us
        if ending.fault is not None and ending.fault.cause is FaultCause.PAUSED:
            self.gcs.phase(f"pausing: {ending.fault.detail}")  # an operator's, not a fault
        elif ending.fault is not None:
            self.gcs.fault(ending.fault.cause.value, ending.fault.detail)
        if ap is not None and touched:
            pose = ending.last_pose or (ap.state.pose.ned if ap.state.pose else None)
            async with phase("stop", self.notifier, self.display):
                secured = await fall_back(
                    ending.fault,
                    sink=held.sink,
                    autopilot=ap.action,
                    cfg=self.cfg.safety,
                    detected_s=ending.detected_s or time.monotonic(),
                    pose_text=self._pose_text(pose),
                    disarm=disarm_after(held.armed_by_us, ending),
                    abandon=lambda: self.stop.forced,
                )
            report_fallback(self.gcs, secured)
        if ending.code is ExitCode.OK:
            self.gcs.phase("mission complete")
        await self.gcs.close()
        if held.sink is not None:
            await self._bounded_close("sink", held.sink.close())
        if ap is not None and self.opts.link is None:  # the service's link stays up
            ap.stop_heartbeat()
            await self._bounded_close("link", ap.close())
        self.notifier.close()

    async def _bounded_close(self, what: str, closing: Awaitable[None]) -> None:
        """Closing must neither hang the exit nor mask the outcome: the vehicle is already
        secured. Bounded by ``safety.fallback_deadline_s``, like the fall-back's stop."""
        bound_s = self.cfg.safety.fallback_deadline_s
        try:
            await asyncio.wait_for(closing, timeout=bound_s)
        except TimeoutError:
            log.error("close_late", what=what, timeout_s=bound_s)
        except Exception:
            log.exception("close_failed", what=what)

    def _build_summary(
        self, fault: str | None, code: ExitCode, wall_duration_s: float | None
    ) -> RunSummary:
        summary = self.summary.build(
            completed=code is ExitCode.OK,
            fault=fault,
            exit_code=int(code),
            mission_name=self.opts.mission.name,
            mode=self.opts.mission.mode.value,
            waypoints_total=self._numbering().operator_count,
            via_points_total=sum(w.via for w in self.opts.mission.waypoints),
            wall_duration_s=wall_duration_s,
        )
        if self.opts.inputs is not None and self.opts.inputs.resumed_from is not None:
            summary = summary.model_copy(update={"resumed_from": self.opts.inputs.resumed_from})
        return summary

    def _finish(self, ending: Ending, started: float) -> RunSummary:
        fault = ending.fault
        summary = self._build_summary(
            None if fault is None else f"{fault.cause.value}: {fault.detail}",
            ending.code,
            time.monotonic() - started,
        )
        run_dir = self.recorder.run_dir if self.recorder else None
        # the one ``result`` event goes out while events.jsonl is still attached
        self.display.log_result(summary, run_dir)
        if self.recorder is not None:
            self.recorder.finish(summary)
        self.display.final(summary, run_dir, log_event=False)
        return summary

    # -- loop callbacks (cheap: called at the control rate, after the command left) -------------

    def _on_row(self, row: FlightRow) -> None:
        self.summary.add(row)
        self.display.autopilot_time(row.t_boot_s)
        if self.recorder is not None:
            self.recorder.record(row)

    def _numbering(self) -> Numbering:
        """The operator's numbering of this run's waypoints: 1-based over the whole mission
        (a resumed run continues the count), the planner's via points not counted."""
        if self._plan_vias is not None and self.opts.mission.has_commands():
            vias = list(self._plan_vias)
        else:
            vias = [w.via for w in self.opts.mission.waypoints]
        inputs = self.opts.inputs
        return Numbering.of(vias) if inputs is None else inputs.numbering(vias)

    def _on_arrival(
        self, index: int, numbering: Numbering, t_boot_s: float, error_m: float
    ) -> None:
        number, via = numbering.number(index), numbering.via(index)
        if not via:
            self.gcs.waypoint(number - 1, numbering.total)
        self.summary.arrival(index, t_boot_s, error_m, number=number, via=via)
        start = self.summary.start_t_boot_s
        log.info(
            "waypoint_reached",
            waypoint=numbering.label(index),  # as the ground station numbers it: "3/5"
            index=index,  # 0-based plan index, via points included (what --resume counts)
            elapsed_autopilot_s=(
                round(t_boot_s - start, 1) if start is not None and t_boot_s >= start else None
            ),
            t_boot_s=round(t_boot_s, 2),
            error_m=round(error_m, 3),
        )


async def run_mission(opts: RunOptions) -> RunOutcome:
    return await MissionRunner(opts).run()
