"""``helixd run``: three explicit phases, startup → main_loop → shutdown.

* :meth:`MissionRunner.startup` — connect → preflight → start gate → set MANUAL → arm (each a
  function of :mod:`helixd.runtime.setup`); returns a :class:`Ready` (the link, the sink, the
  plan, the mission frame, the start pose);
* :meth:`MissionRunner.main_loop` — fly; returns an :class:`Ending`;
* :meth:`MissionRunner.shutdown` — always: scrolls to neutral, every override released, HOLD
  requested (:func:`helixd.safety.supervisor.fall_back`), then the sink and the link closed,
  each bounded in time like the fall-back.

Each sub-phase is logged with its duration (``phase_start`` / ``phase_end``). What startup has
taken hold of so far (link, sink, "we armed it") is kept in a :class:`helixd.runtime.setup.Held`
ledger that shutdown gives back, whatever stopped startup half way. Where the flight runs (its
link, signals, start gate) is its host (:mod:`helixd.runtime.host`): ``helixd run`` its own,
``helixd serve`` the service's.

An exception ends the run through one table (:data:`helixd.runtime.ending.EXIT_RULES`): it
maps the exception *and the stage it came from* to a fault cause and an exit code.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import os
from collections.abc import AsyncIterator, Awaitable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import structlog

from helixd import __version__
from helixd.actuators.base import ActuatorSink
from helixd.base.clock import now_s, on_simulated_clock
from helixd.base.exitcodes import ExitCode
from helixd.base.frames import MissionFrame, NedPose
from helixd.base.media import MediaMapNe
from helixd.base.plan import Numbering, Plan, program_numbering
from helixd.config.load import config_to_yaml
from helixd.config.root import HelixdConfig
from helixd.control.estimate import TimeEstimate
from helixd.link.connection import Autopilot
from helixd.mav.constants import MAV_SEVERITY_WARNING
from helixd.mav.url import LinkError
from helixd.mission.expand import DEFAULT_OPTIONS, ExpandOptions
from helixd.mission.judge import patrol_times_s, plan_time_estimate
from helixd.mission.model import Mission
from helixd.mission.resume import RUN_RESUMED_EVENT, RunInputs
from helixd.prepare.ground_learning import learn_from_run
from helixd.prepare.media import MediaRefused, read_media
from helixd.prepare.planned import Replanner
from helixd.recorder.payload_log import PayloadLog
from helixd.recorder.retention import check_free_space, prune_runs
from helixd.recorder.rundir import RecorderUnavailable, RunRecorder
from helixd.recorder.summary import RunSummary, SummaryBuilder
from helixd.report.display import ProgressDisplay, result_line
from helixd.report.gcs_feed import GcsFeed, report_fallback
from helixd.report.notify import ServiceNotifier
from helixd.runtime.arming import arm, confirm_mode, start_gate
from helixd.runtime.ending import (
    Ending,
    ExitRule,
    Stage,
    as_item_numbers,
    ending_after_fallback,
    ending_for,
    ending_of_flight,
    problems_of,
)
from helixd.runtime.flight import FlightLoop
from helixd.runtime.host import FlightHost, OwnLink
from helixd.runtime.in_flight import InFlight
from helixd.runtime.mission_commands import MissionCommands
from helixd.runtime.mode_gate import MANUAL_MODE
from helixd.runtime.placing import (
    autopilot_home,
    checked_from_rover,
    judge_autopilot_fence,
    mission_frame,
    resolve_flight,
    show_checked_plan,
    start_pose,
)
from helixd.runtime.setup import (
    Checked,
    Held,
    PreflightFailed,
    StopBeforeFlight,
    feeding,
    fresh_pose,
    preflight,
    start_sink,
    until_stopped,
)
from helixd.safety.supervisor import fall_back, late_failsafe
from helixd.safety.watchdogs import (
    HANDED_CAUSES,
    NEXT_FLIGHT_CAUSES,
    STOP_CAUSES,
    FaultCause,
)

log = structlog.get_logger(__name__)


@dataclass(frozen=True)
class RunOptions:
    """What to fly and where to record it (never written by the run)."""

    cfg: HelixdConfig
    mission: Mission
    mission_yaml: str
    connect_url: str
    run_root: Path
    tty: bool
    # not on a terminal and the console quieter than info: plain progress lines and the table
    plain_progress: bool = False
    # planning: the mission with its first leg re-planned from the rover's (north_m, east_m)
    # (and the EKF origin's (lat, lon), for a global mission)
    replan_from: Replanner | None = None
    show_plan: bool = (
        False  # upload the resolved plan for the GCS to draw (helixd.runtime.show_plan)
    )
    # preflight reads the autopilot's own fence and judges the route (helixd serve reads it
    # with the mission itself and downloads while idle: a second download would race it)
    autopilot_fence: bool = True
    # inputs.json (mission/config hashes, resume link); None: no record (not resumable)
    inputs: RunInputs | None = None
    options: ExpandOptions = DEFAULT_OPTIONS  # --strict / --skip-unsupported (commands)
    # a ground-station mission: refusals name its entries by mission item ("item 3")
    item_numbers: bool = False


@dataclass
class RunOutcome:
    exit_code: ExitCode
    summary: RunSummary | None
    run_dir: Path | None
    messages: list[str] = field(default_factory=list)
    cause: FaultCause | None = None  # what ended the flight (None: completed, or never flown)


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
    t0 = now_s()
    log.info("phase_start", phase=name)
    notifier.status(f"phase: {name}")
    display.phase(name)
    end = PhaseEnd()
    try:
        yield end
    except BaseException:
        log.info("phase_end", phase=name, ok=False, duration_wall_s=round(now_s() - t0, 3))
        raise
    cause = {} if end.cause is None else {"cause": end.cause}
    log.info("phase_end", phase=name, ok=end.ok, **cause, duration_wall_s=round(now_s() - t0, 3))


def disarm_after(armed_by_us: bool, ending: Ending, when_complete: bool = True) -> bool | None:
    """Whether the fall-back disarms (pure). A completed mission always ends disarmed, even
    on a vehicle someone else armed (a ground station after a takeover): exit 0 means
    disarmed, and a finished rover left armed in HOLD is one switch away from moving. What
    we armed is also disarmed after an operator's stop signal (Ctrl-C, SIGTERM: nobody
    drives it now). After a fault, a pilot's takeover (the pilot may be driving it) or a
    stop on a vehicle we did not arm, ``safety.disarm_on_fault`` decides (None). A flight of
    ``helixd serve`` with ``serve.disarm_when_complete`` false (``when_complete``) ends a
    completed mission armed in HOLD, as ArduPilot's AUTO does."""
    if ending.code is ExitCode.OK:
        return when_complete
    if ending.fault is not None and ending.fault.cause in HANDED_CAUSES:
        return False  # the pilot drives it, or the next flight does
    if not armed_by_us:
        return None
    if ending.fault is not None and ending.fault.cause in STOP_CAUSES:
        return True
    return None


def log_estimate(plan: Plan, estimate: TimeEstimate, time_limit_s: float) -> None:
    """The flight's time estimate in the log; a patrol's by its laps."""
    patrol = patrol_times_s(plan, estimate)
    if patrol is None:
        log.info("flight_estimate", estimated_s=round(estimate.total_s, 1), pivots=estimate.pivots)
    else:  # flown until stopped: the planned laps' total is no estimate of the flight
        log.info(
            "flight_estimate",
            patrol_first_lap_s=round(patrol[0], 1),
            patrol_lap_s=round(patrol[1], 1),
            ends_by="stop or safety.mission_time_limit_s",
            time_limit_s=time_limit_s,
        )


@dataclass(frozen=True)
class Ready:
    """What startup hands to the main loop."""

    ap: Autopilot
    sink: ActuatorSink
    plan: Plan
    frame: MissionFrame
    start_ned: NedPose
    cfg: HelixdConfig  # with the mission's own fence and time limit in place (exact now)


class MissionRunner:
    """Owns one run: startup → main_loop → shutdown, and the run's outputs (recorder, summary,
    operator messages). Where it runs (link, signals, start gate) is its ``host``'s."""

    def __init__(self, opts: RunOptions, host: FlightHost | None = None) -> None:
        self.opts = opts
        self.cfg = opts.cfg
        self.host: FlightHost = host or OwnLink()
        self.stop = self.host.stop
        self.notifier = self.host.notifier
        self.display = ProgressDisplay(tty=opts.tty, plain_lines=opts.plain_progress)
        self.recorder: RunRecorder | None = None
        self.summary = SummaryBuilder()
        self.messages: list[str] = []
        self.gcs = GcsFeed(
            self.cfg.gcs_report
        )  # what the ground station sees (helixd.report.gcs_feed)
        # the mission flown: opts.mission, its first leg re-planned from the rover in preflight
        self.mission = opts.mission
        self._payload: PayloadLog | None = None  # payload.csv while the link is ours
        # the plan as flown (set at preflight, again at the flight's start): a program expands
        # the mission (its waypoints are the plan's, jumps repeated) and is numbered by item
        self._plan: Plan | None = None
        self._origin: tuple[float, float] | None = None  # the EKF origin preflight found
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

    def set_cruise(self, asked_mps: float) -> tuple[float, str] | None:
        """The operator's change of speed (``helixd serve``): see :meth:`FlightLoop.set_cruise`;
        None when not flying."""
        loop = self.flight_loop
        return None if loop is None else loop.set_cruise(asked_mps)

    # -- startup ------------------------------------------------------------------------------

    async def startup(self, held: Held) -> Ready:
        """connect → preflight → start gate → MANUAL → arm. Returns what the flight needs."""
        cfg, stop = self.cfg, self.stop
        async with feeding(held, cfg, self.notifier):
            async with phase("connect", self.notifier, self.display):
                run_dir = self.recorder.run_dir if self.recorder is not None else None
                ap = await self.host.open(cfg, held, self._gcs_on, run_dir)
                self._payload = open_payload_log(ap, cfg, self.mission, run_dir)
                if ap.tlog is not None and self.recorder is not None:  # link.tlog cut: ours
                    ap.tlog.writer.on_error = self._tlog_cut
            if self.host.tells_steps:
                self.gcs.phase("preflight")
            async with phase("preflight", self.notifier, self.display):
                checked = await until_stopped(stop, self._preflight(ap))
            if self.opts.show_plan:  # for the GCS to draw; never flown (helixd.runtime.show_plan)
                self._warn(await show_checked_plan(ap, cfg, checked, stop))
            # READY once preflight passed: the start gate may wait minutes for the pilot, and
            # systemd's TimeoutStartSec must not kill that wait; the watchdog runs from here on.
            self.notifier.ready("preflight passed")
            if self.host.start_gate:
                async with phase("start_gate", self.notifier, self.display):
                    await start_gate(ap, cfg, stop, self.notifier)
            if self.host.driving.mode == MANUAL_MODE:
                async with phase("set_manual", self.notifier, self.display):
                    await until_stopped(stop, ap.action.set_mode(MANUAL_MODE))
                    await confirm_mode(ap, cfg, MANUAL_MODE)
            sink = held.sink if held.sink is not None else await start_sink(cfg, ap, held)
            if self.host.driving.mode == MANUAL_MODE:
                async with phase("arm", self.notifier, self.display):
                    self._warn(await until_stopped(stop, arm(ap, cfg, held, self.display.phase)))
                self.gcs.phase("armed")
            elif not ap.state.armed:  # the crew armed it; a disarm since ends the start
                raise PreflightFailed(
                    [f"the autopilot is not armed (mode {ap.state.mode}): arm it first"]
                )
            now = await fresh_pose(ap, cfg, stop)
            # checked again from where it starts: the mission's own geofence placed exactly
            # (origin and start known), its time limit and ground in force
            placed = start_pose(checked, now, ap, cfg, self.opts.options)
        start_ned, plan = placed.start_ned, checked.plan
        if self.mission.has_commands():
            # from where the rover is now, to the home the autopilot set when it armed
            home = await autopilot_home(ap, cfg, self.mission, checked.origin, stop)
            args = (self.mission, cfg, checked.origin, start_ned, home or checked.home)
            plan, _ = resolve_flight(*args, self.opts.options, self.opts.inputs)
        frame = mission_frame(self.mission, start_ned)
        return Ready(ap, sink, plan, frame, start_ned, placed.cfg)

    async def _preflight(self, ap: Autopilot) -> Checked:
        """The vehicle, then the mission placed from its pose; the summary's estimate."""
        vehicle = await preflight(ap, self.cfg, self.mission, self.stop, self._warn)
        checked = await checked_from_rover(
            ap,
            self.cfg,
            self.mission,
            vehicle,
            self.stop,
            replan_from=self.opts.replan_from,
            inputs=self.opts.inputs,
            options=self.opts.options,
        )
        self.mission = checked.mission
        plan = checked.plan
        if self.opts.autopilot_fence:
            await judge_autopilot_fence(ap, checked, self._warn)
        last = plan.waypoints[-1]
        # a resume's approach to the interrupted leg is not the mission's cross-track error
        join_m = None if plan.leg_start_xy_m is None else self.cfg.control.stop_tolerance_m
        estimate = plan_time_estimate(plan, self.cfg, checked.start_ned)  # as `check` says
        limit_s = self.mission.time_limit_s or self.cfg.safety.mission_time_limit_s
        log_estimate(plan, estimate, limit_s)
        if self.recorder is not None and self.recorder.run_dir is not None:
            low_space = check_free_space(self.recorder.run_dir, estimate.total_s)
            if low_space is not None:
                self._warn(low_space)
                self.gcs.say("low disk space for the flight record", MAV_SEVERITY_WARNING)
        self.summary = SummaryBuilder(
            final_xy_m=(last.x_m, last.y_m), join_m=join_m, estimated_s=estimate.total_s
        )
        self._plan = plan
        self._origin = checked.origin
        if checked.origin is not None:
            self.summary.set_origin(*checked.origin)
        return checked

    def _gcs_on(self, ap: Autopilot) -> None:
        self.gcs.start(ap.send_message)

    def _tlog_cut(self, path: Path, exc: OSError) -> None:
        if self.recorder is not None:
            self.recorder.cut(path, exc, stage="tlog")

    def _record_cut(self, text: str) -> None:
        """The recorder's one record-cut warning, to the ground station at once."""
        self.gcs.say(text, MAV_SEVERITY_WARNING)

    def _warn(self, warning: str | None) -> None:
        """A warning for the operator (printed after the run)."""
        if warning is not None:
            self.messages.append(f"warning: {warning}")

    # -- main loop ----------------------------------------------------------------------------

    async def main_loop(self, ready: Ready) -> Ending:
        """Fly the plan; the loop returns its own ending (done, a watchdog, a signal)."""
        self._plan = ready.plan  # as flown: a mission with commands was placed again after arming
        ap = ready.ap
        commands = MissionCommands(ap.action)
        if ready.plan.program is not None:
            commands.start()
        feed = InFlight(
            cfg=self.cfg,
            plan=ready.plan,
            numbering=self.numbering(),
            ap=ap,
            host=self.host,
            gcs=self.gcs,
            display=self.display,
            summary=self.summary,
            recorder=self.recorder,
            media=self._placed_media(),
        )
        feed.announce(self.mission.name)
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
                    hooks=feed.hooks(on_action=commands.submit),
                    driving=self.host.driving,
                )
                result = await self.flight_loop.run()
            finally:
                self.flight_loop = None
                feed.journal.drain()  # every step reaches flight.csv and the summary
                # the payload commands already due still go out (bounded), before the stop
                await commands.close(self.cfg.safety.fallback_deadline_s)
            if result.fault is not None:  # e.g. Ctrl-C: an operator stop, not "ok"
                fly.failed(result.fault.cause.value)
        return ending_of_flight(result)

    # -- the run ------------------------------------------------------------------------------

    async def run(self) -> RunOutcome:
        try:
            with self.host.signals():
                return await self._run()
        except Exception as exc:  # escaped the shutdown path itself: still end with a result
            log.exception("internal_error")
            fault = f"{FaultCause.EXCEPTION.value}: {type(exc).__name__}: {exc}"
            summary = self._build_summary(fault, ExitCode.INTERNAL_ERROR, None)
            run_dir = self.recorder.run_dir if self.recorder else None
            messages = [*self.messages, result_line(summary)]
            return RunOutcome(
                ExitCode.INTERNAL_ERROR, summary, run_dir, messages, FaultCause.EXCEPTION
            )
        finally:
            self.display.close()

    async def _run(self) -> RunOutcome:
        # A link never made is a connect failure, not a flight: no run directory, no fault.
        # A run root that cannot be written is refused first, without connecting.
        try:
            reached = await self.host.reach(self.cfg) if _may_write(self.opts.run_root) else None
        except LinkError as exc:
            url = self.opts.connect_url
            line = f"error: could not connect to {url}: {str(exc).removeprefix(f'{url}: ')}"
            return RunOutcome(ExitCode.LINK, None, None, [line])
        except StopBeforeFlight:
            by = self.host.stop.signal_name or "a stop request"
            line = f"stopped by {by} while connecting to {self.opts.connect_url}; nothing recorded"
            return RunOutcome(ExitCode.OPERATOR_STOP, None, None, [line])
        try:
            self.recorder = open_recorder(self.opts, self.mission)
        except RecorderUnavailable as exc:
            if reached is not None:
                await self._bounded_close("link", self.host.close(reached))
            summary = self._build_summary(f"recorder: {exc}", ExitCode.PREFLIGHT, None)
            return RunOutcome(ExitCode.PREFLIGHT, None, None, [str(exc), result_line(summary)])
        self.recorder.on_cut = self._record_cut
        prune_runs(
            self.opts.run_root,
            self.cfg.recorder.keep_runs,
            self.cfg.recorder.keep_bytes,
            self.recorder.run_dir,
        )
        log.info(
            "helixd_start",
            version=__version__,
            mission=self.mission.name,
            connect=self.opts.connect_url,
            run_dir=str(self.recorder.run_dir),
        )
        resumed = None if self.opts.inputs is None else self.opts.inputs.resumed_from
        if resumed is not None and self.opts.inputs is not None:
            log.info(
                RUN_RESUMED_EVENT,
                resumed_from=resumed.path,
                resumed_mission_sha256=resumed.mission_sha256,
                first_waypoint=self.numbering().label(0),
            )
        started = now_s()
        held = Held()
        ending = Ending(None, ExitCode.INTERNAL_ERROR)  # if cancelled before an ending is known
        try:
            ending = await self._startup_then_fly(held)
        finally:
            ending = await self.shutdown(held, ending)
        summary = self._finish(ending, started)
        self._learn_ground()
        return RunOutcome(
            ending.code,
            summary,
            self.recorder.run_dir if self.recorder else None,
            [*self.messages, result_line(summary)],  # the plain result line comes last
            None if ending.fault is None else ending.fault.cause,
        )

    async def _startup_then_fly(self, held: Held) -> Ending:
        stage = Stage.SETUP
        try:
            ready = await self.startup(held)
            stage = Stage.FLIGHT
            return await self.main_loop(ready)
        except Exception as exc:
            if self.opts.item_numbers:  # a ground-station mission: its entries are items
                exc = as_item_numbers(exc)
            ending, rule = ending_for(exc, stage, now_s())
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

    async def shutdown(self, held: Held, ending: Ending) -> Ending:
        """Always: stop the scrolls, release overrides, ask for HOLD (if we touched anything);
        then close the sink and the link, each bounded like the fall-back. Returns the
        ending, renamed when a takeover by mode change turns out, after the fall-back, to be
        ArduPilot's failsafe (its text came after the mode change)."""
        self.notifier.stopping()
        ap = held.ap
        touched = held.sink is not None or held.armed_by_us
        if ending.fault is not None and ending.fault.cause is FaultCause.PAUSED:
            self.gcs.phase(f"pausing: {ending.fault.detail}")  # an operator's, not a fault
        elif ending.fault is not None and ending.fault.cause is FaultCause.RELEASED:
            pass  # the flight loop told the GCS already (released: the pilot drives)
        elif ending.fault is not None and ending.fault.cause in NEXT_FLIGHT_CAUSES:
            if self.host.tells_steps:  # else the next flight's own text says where
                self.gcs.phase(ending.fault.detail)
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
                    detected_s=ending.detected_s or now_s(),
                    pose_text=pose_text(pose),
                    disarm=disarm_after(held.armed_by_us, ending, self.host.disarm_when_complete),
                    abandon=lambda: self.stop.forced,
                )
            report_fallback(self.gcs, secured)
            self.host.secured(secured)
            ending = self._late_failsafe(ending, ap)
            ending = ending_after_fallback(ending, secured, self.host.disarm_when_complete)
        if ending.code is ExitCode.OK:
            self.gcs.phase("mission complete")
        await self.gcs.close()
        if held.sink is not None:
            await self._bounded_close("sink", held.sink.close())
        if self._payload is not None:
            self._payload.close()
            self._payload = None
        if ap is not None:
            await self._bounded_close("link", self.host.close(ap))
        self.notifier.close()
        return ending

    def _late_failsafe(self, ending: Ending, ap: Autopilot) -> Ending:
        named = late_failsafe(
            ending.fault,
            ending.detected_s,
            ap.state,
            self.cfg.safety.autopilot_failsafe_window_s,
        )
        if named is None or ending.fault is None:
            return ending
        log.warning(
            "fault_renamed",
            cause=named.cause.value,
            detail=named.detail,
            was=ending.fault.cause.value,
        )
        self.gcs.fault(named.cause.value, named.detail)
        return Ending(named, ExitCode.FAULT, ending.detected_s, ending.last_pose)

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
        numbering = self.numbering()
        summary = self.summary.build(
            completed=code is ExitCode.OK,
            fault=fault,
            exit_code=int(code),
            mission_name=self.mission.name,
            mode=self.mission.mode.value,
            waypoints_total=numbering.operator_count,
            via_points_total=sum(numbering.vias),  # the media map's stops included
            wall_duration_s=wall_duration_s,
            items_total=numbering.total if numbering.items else None,
        )
        if on_simulated_clock():  # its "wall" seconds are simulated ones
            summary = summary.model_copy(update={"companion_clock": "simulated"})
        if self.opts.inputs is not None and self.opts.inputs.resumed_from is not None:
            summary = summary.model_copy(update={"resumed_from": self.opts.inputs.resumed_from})
        program = None if self._plan is None else self._plan.program
        if program is not None and program.patrol_item:
            summary = summary.model_copy(update={"patrol_item": program.patrol_item})
        return summary

    def _finish(self, ending: Ending, started: float) -> RunSummary:
        fault = ending.fault
        summary = self._build_summary(
            None if fault is None else f"{fault.cause.value}: {fault.detail}",
            ending.code,
            now_s() - started,
        )
        if self.recorder is not None:  # the RESULT line says from when the record is missing
            summary = self.recorder.annotate(summary)
        run_dir = self.recorder.run_dir if self.recorder else None
        # the one ``result`` event goes out while events.jsonl is still attached
        self.display.log_result(summary, run_dir)
        if self.recorder is not None:
            self.recorder.finish(summary)
        self.display.final(summary, run_dir, log_event=False)
        return summary

    def _placed_media(self) -> MediaMapNe | None:
        """The flight's media map placed with the EKF origin (flight.csv's medium column)."""
        try:
            media = read_media(self.cfg, self.mission)
            return None if media is None else media.to_ne(self._origin)
        except (MediaRefused, ValueError):
            return None

    def _learn_ground(self) -> None:
        """After the record is closed: what the ground delivered, into the profile."""
        try:
            media = read_media(self.cfg, self.mission)
        except MediaRefused:
            return  # refused before the flight already, or changed since: nothing to learn
        run_dir = self.recorder.run_dir if self.recorder else None
        learn_from_run(self.cfg, media, run_dir, self.opts.run_root)

    # -- numbering ----------------------------------------------------------------------------

    def numbering(self) -> Numbering:
        """The operator's numbering of this run's waypoints: 1-based over the whole mission
        (a resumed run continues the count), the planner's via points not counted."""
        if self._plan is not None and self.mission.has_commands():
            items = program_numbering(self._plan)  # a mission with commands: its items
            if items is not None:
                return items
            vias = [w.via for w in self._plan.waypoints]
        elif self._plan is not None and len(self._plan.waypoints) > len(self.mission.waypoints):
            vias = [w.via for w in self._plan.waypoints]  # with the media map's via stops
        else:
            vias = [w.via for w in self.mission.waypoints]
        inputs = self.opts.inputs
        return Numbering.of(vias) if inputs is None else inputs.numbering(vias)


def pose_text(ned: NedPose | None) -> str:
    """The pose the fall-back reports, for the operator."""
    if ned is None:
        return "unknown"
    return (
        f"N {ned.north_m:.2f} m, E {ned.east_m:.2f} m, "
        f"yaw {math.degrees(ned.yaw_ned_rad) % 360:.0f}° (NED)"
    )


def _may_write(root: Path) -> bool:
    """Whether the run root (or the nearest folder it would be made in) looks writable."""
    where = root
    while not where.exists() and where.parent != where:
        where = where.parent
    return where.is_dir() and os.access(where, os.W_OK)


def open_payload_log(
    ap: Autopilot, cfg: HelixdConfig, mission: Mission, run_dir: Path | None
) -> PayloadLog | None:
    """``payload.csv`` in ``run_dir`` from now until the link is given back, each reading's
    medium from the flight's media map (None: no run directory, or ``payload.enabled`` off)."""
    if run_dir is None:
        return None
    try:
        media = read_media(cfg, mission)
    except MediaRefused:
        media = None  # prepare_flight refused it already; the readings go without a medium
    return PayloadLog.attach(ap, cfg.payload, run_dir, media)


def open_recorder(opts: RunOptions, mission: Mission) -> RunRecorder:
    """The run directory for one run of ``mission`` (config, mission and inputs written)."""
    return RunRecorder.create(
        run_root=opts.run_root,
        mission_name=mission.name,
        config_yaml=config_to_yaml(opts.cfg),
        mission_yaml=opts.mission_yaml,
        cfg=opts.cfg.recorder,
        now_utc=datetime.now(UTC),
        inputs_json=None if opts.inputs is None else opts.inputs.to_json(),
    )


async def run_mission(opts: RunOptions, host: FlightHost | None = None) -> RunOutcome:
    """One run of ``opts`` on ``host`` (None: its own link, signals and start gate)."""
    return await MissionRunner(opts, host).run()
