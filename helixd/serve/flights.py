"""The flights of ``helixd serve``, one at a time, each a
:class:`helixd.runtime.daemon.MissionRunner` on the service's link: what a start flies (the
checked mission, from the autopilot's item, or the interrupted run's remainder), the flight
run as a task, and its end told to the crew and recorded for a continue (the state file)."""

from __future__ import annotations

import asyncio
import json
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from functools import partial
from pathlib import Path
from typing import NamedTuple

import structlog

from helixd.base.clock import now_s
from helixd.base.plan import Numbering
from helixd.base.run_files import EVENTS_FILE, SUMMARY_FILE
from helixd.config.root import HelixdConfig
from helixd.link.connection import Autopilot
from helixd.link.services.command_client import CommandError
from helixd.link.vehicle import PositionTarget
from helixd.mav.constants import (
    MAV_SEVERITY_ERROR,
    MAV_SEVERITY_INFO,
    MAV_SEVERITY_NOTICE,
    MAV_SEVERITY_WARNING,
)
from helixd.mav.url import LinkError
from helixd.mission.expand import ExpandOptions
from helixd.mission.resume import autopilot_step_held, last_step_started, with_walk
from helixd.prepare.builder import (
    AutopilotPlace,
    AutoWalk,
    Resume,
    continue_commands,
    from_autopilot_item,
    prepare_flight,
)
from helixd.prepare.inputs import InputsRefused
from helixd.prepare.planned import Flight
from helixd.recorder.closing import close_killed_run, cut_run
from helixd.recorder.events import read_events
from helixd.recorder.summary import RunSummary
from helixd.runtime.daemon import MissionRunner, RunOptions, RunOutcome
from helixd.runtime.host import OnLink, ServeHost
from helixd.runtime.mode_gate import AUTO_MODE, DRIVE_MANUAL, Driving, PlaceRule, crew_mode_of
from helixd.runtime.setup import Held
from helixd.runtime.signals import StopRequest
from helixd.safety.supervisor import HOLD_MODE
from helixd.safety.watchdogs import HANDED_CAUSES, NEXT_FLIGHT_CAUSES, FaultCause
from helixd.serve.check import ReadyMission, Verdict
from helixd.serve.core import (
    AutoWatch,
    Request,
    ServeState,
    SwitchWatch,
    crew_paused,
    state_after_flight,
)
from helixd.serve.mission import MissionWatch
from helixd.serve.options import ServeOptions
from helixd.serve.status import ServeStatus

log = structlog.get_logger(__name__)


@dataclass(frozen=True, slots=True)
class Interrupted:
    """The run a continue goes on from: of the mission with this fingerprint (the state
    file's record)."""

    fingerprint: str
    run_dir: Path


class ToFly(NamedTuple):
    """What a start flies: the flight, its config (the mission's limits), and where its run
    directory goes (an interrupted run's continue: beside that run)."""

    flight: Flight
    cfg: HelixdConfig
    run_root: Path


@dataclass(frozen=True, slots=True)
class WalkLetGo:
    """The last AUTO flight of a mission with commands let go with the autopilot armed (a
    release, a handover): the autopilot keeps its jump counters, the next AUTO flight of the
    same mission walks on from where this one was (:func:`held_walk`)."""

    fingerprint: str
    options: ExpandOptions  # the walk it flew
    run_dir: Path


def after_flight(watch: AutoWatch, cause: FaultCause | None, hold_acked_s: float | None) -> None:
    """What a flight's end leaves the AUTO watch: after a release or a handover (the crew's
    own mode) AUTO again starts the next at once; after a fall-back whose HOLD the autopilot
    acknowledged at ``hold_acked_s``, the first mode report after that is news (AUTO: the
    crew's Start), as after a refused start; else the autopilot must first be seen out of
    AUTO, so a flight ending with the autopilot still in AUTO never starts the next itself."""
    if cause in HANDED_CAUSES:  # the crew's doing: the mission's verdict stands
        watch.flight_ended(left_auto=True)
    elif hold_acked_s is not None:
        watch.left(hold_acked_s)
    else:
        watch.flight_ended(left_auto=False)


@dataclass
class RecordedHost(ServeHost):
    """The service's host for one flight, told the flight's run directory as the flight opens
    it, before anything is driven (``on_run_dir``: the state file's record of the flight
    under way, :meth:`Flights._under_way`)."""

    on_run_dir: Callable[[Path | None], None] | None = None

    async def open(
        self, cfg: HelixdConfig, held: Held, on_link: OnLink, run_dir: Path | None
    ) -> Autopilot:
        if self.on_run_dir is not None:
            self.on_run_dir(run_dir)
        return await super().open(cfg, held, on_link, run_dir)


# modes an armed autopilot drives in by itself: a refused start leaves it there in HOLD
SELF_DRIVING_MODES = (AUTO_MODE, "GUIDED")


class Flights:
    """The service's flight in progress (at most one), and what the last ones left: the
    interrupted run a continue goes on from, the walk of an AUTO flight let go, and the AUTO
    watch a flight's end rearms. It reads the mission watch and tells its verdict itself
    (:meth:`read_mission`: while idle, and again at each start)."""

    def __init__(
        self,
        opts: ServeOptions,
        mission: MissionWatch,
        status: ServeStatus,
        switch: SwitchWatch | None,
        service_stop: StopRequest,
    ) -> None:
        self.opts = opts
        self.cfg = opts.cfg
        self.mission = mission  # read again, and its verdict told, by :meth:`read_mission`
        self.status = status
        self.auto_watch = AutoWatch()  # the crew's start: the autopilot armed in AUTO
        self.switch = switch  # the radio's start switch, when there is one: low refuses
        self._service_stop = service_stop
        self.busy = False  # a start taken, its flight not yet under way
        self.task: asyncio.Task[None] | None = None
        self.stop: StopRequest | None = None
        self.runner: MissionRunner | None = None  # while a flight runs
        self.count = 0
        self._current_item: int | None = None  # the item last set as the autopilot's current
        # MissionWatch.plan_changes when the flight in progress read its plan: a change since
        # and the autopilot holds another mission, where this flight's item numbers mean others
        self._plan_changes = 0
        self._plan_change_told = False
        self._side_tasks: set[asyncio.Task[None]] = set()
        self.interrupted = read_state_file(opts.state_file)
        # a flight the last start of the service never ended (killed): its run directory
        # closed now, the crew told once (:meth:`take_cut_text`) that a start continues it
        self.cut_text: str | None = None
        self._close_killed(opts.state_file)
        self.auto_walk: WalkLetGo | None = None
        # the last flight ended on the crew's new current item: the next AUTO flight drives
        # there from where the rover is, not along the skipped leg
        self.item_set = False

    @property
    def flying(self) -> bool:
        return self.task is not None

    def resumable(self, checked: ReadyMission | None) -> bool:
        """A start continues the interrupted run: it was of the mission checked now."""
        return (
            self.interrupted is not None
            and checked is not None
            and self.interrupted.fingerprint == checked.fingerprint
        )

    def holding(self) -> bool:
        return self.runner is not None and self.runner.holding_forever()

    # -- a flight cut by a kill ---------------------------------------------------------------

    def _close_killed(self, state_file: Path) -> None:
        """The run directory the state file names as under way, without a summary (its
        writer was killed: no fall-back, no summary, no record of its end), closed from what
        it recorded; the flight it was is interrupted (the record's own run: a continue goes
        on from its first waypoint not reached, as after a SIGTERM)."""
        open_run = read_open_run(state_file)
        if open_run is None:
            return
        if not cut_run(open_run):  # killed after its summary, before the record of its end
            if self.interrupted is not None and completed_run(open_run):
                self.interrupted = None
            return
        summary = close_killed_run(open_run)
        cut = self.interrupted is not None and self.interrupted.run_dir == open_run
        log.warning(
            "serve_flight_cut",
            run_dir=str(open_run),
            closed=summary is not None,
            waypoints_reached=None if summary is None else summary.waypoints_reached,
            rows=None if summary is None else summary.rows,
            continues=cut,
        )
        then = "a start continues it" if cut else "the rover was left as it was"
        self.cut_text = f"helixd restarted: the last flight was cut; {then}"
        write_state_file(state_file, self.interrupted, ServeState.FAULTED)

    def take_cut_text(self) -> str | None:
        """What the crew is told, once, of a flight cut by the service's kill."""
        text, self.cut_text = self.cut_text, None
        return text

    def _under_way(self, fingerprint: str | None, run_dir: Path | None) -> None:
        """A flight opened ``run_dir``: the state file says so before anything is driven,
        so a kill from now on leaves the truth on disk: the run to close at the next start,
        and, a flight of the checked mission (``fingerprint``), the one a continue goes on
        from (a flight to a place: the interrupted run stays the one before)."""
        if run_dir is None:
            return
        cut = self.interrupted if fingerprint is None else Interrupted(fingerprint, run_dir)
        write_state_file(self.opts.state_file, cut, ServeState.FLYING, open_run=run_dir)

    # -- the mission's verdict ----------------------------------------------------------------

    async def read_mission(self, ap: Autopilot) -> None:
        """The mission read again (recheck while IDLE); a new verdict told."""
        verdict = await self.mission.read(ap, recheck=self.status.state is ServeState.IDLE)
        if verdict is not None:
            self.apply(verdict)

    def apply(self, verdict: Verdict) -> None:
        """A mission's verdict: READY with the checked mission (and whether a start continues
        an interrupted run of it), REFUSED (every problem in the log, the first few to the
        GCS) or IDLE."""
        for p in verdict.problems:
            log.error("serve_mission_refused", problem=p)
        if verdict.state is ServeState.REFUSED:
            self.status.set(ServeState.REFUSED, verdict.detail, MAV_SEVERITY_ERROR)
            for text in verdict.more:
                self.status.gcs.say(text, MAV_SEVERITY_ERROR)
            return
        if verdict.checked is None:
            self.status.set(verdict.state, verdict.detail)
            return
        log.info(
            "serve_mission_checked",
            waypoints=verdict.checked.waypoints,
            fingerprint=verdict.checked.fingerprint[:12],
        )
        resume = self.resumable(verdict.checked)
        suffix = " (interrupted: a start continues it)" if resume else ""
        self.status.set(ServeState.READY, verdict.detail + suffix, MAV_SEVERITY_INFO)

    # -- the crew's commands to the flight in progress ----------------------------------------

    def start(self, ap: Autopilot, request: Request, who: str, item: int = 0) -> None:
        self.busy = True  # until the flight is under way (or refused)
        fly = self._fly(ap, request, who, item)
        self.task = asyncio.create_task(self._flying(fly), name="serve-flight")

    def start_goto(self, ap: Autopilot, source: AutopilotPlace, place: PositionTarget) -> None:
        self.busy = True  # until the flight is under way (or refused)
        fly = self._fly_goto(ap, source, place)
        self.task = asyncio.create_task(self._flying(fly), name="serve-goto")

    def pause(self, why: str) -> None:
        if self.stop is not None:
            self.stop.pause(why)

    def release_hold(self) -> None:
        if self.runner is not None:
            self.runner.release_hold()

    def change_speed(self, asked_mps: float | None, who: str) -> None:
        """The crew's change of speed for the flight in progress, told as it was applied."""
        runner = self.runner
        if runner is None or asked_mps is None:
            return
        applied = runner.set_cruise(asked_mps)
        if applied is None:
            return
        speed_mps, limit = applied
        bounded = f" ({asked_mps:g} asked, bounded by {limit})" if limit else ""
        log.info("crew_speed", by=who, asked_mps=asked_mps, speed_mps=round(speed_mps, 3))
        self.status.gcs.say(f"speed {speed_mps:.2f} m/s{bounded}", MAV_SEVERITY_INFO)

    async def close(self, why: str) -> None:
        """The flight in progress stopped through its own fall-back; side tasks ended."""
        task, stop = self.task, self.stop
        if task is not None:
            if stop is not None:
                stop.trigger(why)
            await asyncio.gather(task, return_exceptions=True)
        for side in list(self._side_tasks):
            side.cancel()
        await asyncio.gather(*self._side_tasks, return_exceptions=True)

    # -- flights ------------------------------------------------------------------------------

    def _flight_for(self, request: Request, item: int = 0) -> ToFly:
        """What to fly: the checked mission from item 1 (or ``item``, FROM_ITEM), or the
        interrupted run's remainder."""
        checked = self.mission.checked
        assert checked is not None
        from_here, self.item_set = self.item_set, False
        if request is Request.AUTO:
            held = held_walk(self.auto_walk, checked.fingerprint)
            item_now = self.mission.autopilot_item
            flight = from_autopilot_item(checked.flight, item_now, checked.cfg, held, from_here)
            return ToFly(flight, checked.cfg, self.opts.run_root)
        if request is Request.FROM_ITEM:  # jump counters zero, as AP_Mission::start
            flight = from_autopilot_item(checked.flight, item, checked.cfg)
            return ToFly(flight, checked.cfg, self.opts.run_root)
        interrupted = self.interrupted
        # a continue of a run of another plan (one uploaded since) flies the new one whole
        if request is Request.CONTINUE and interrupted is not None and self.resumable(checked):
            run_dir = interrupted.run_dir
            if checked.flight.mission.has_commands():  # the walk goes on from its step
                flight = continue_commands(checked.flight, run_dir, checked.cfg)
                o = flight.options
                log.info(
                    "serve_continue_walk",
                    run_dir=str(run_dir),
                    first_item=o.first_item,
                    jumps_taken=o.jumps_taken,
                    speed_mps=o.speed_mps,
                    reverse=o.reverse,
                )
                return ToFly(flight, checked.cfg, run_dir.parent)
            resumed = prepare_flight(Resume(run_dir), self.opts.config_path)
            for note in resumed.notes:
                log.info("serve_resume", note=note)
            cfg = resumed.cfg.model_copy(update={"link": self.cfg.link})
            return ToFly(resumed.flight, cfg, run_dir.parent)
        return ToFly(checked.flight, checked.cfg, self.opts.run_root)

    async def _flying(self, flight: Awaitable[None]) -> None:
        """A flight task: whatever ends it, the service is free for the next."""
        try:
            await flight
        finally:
            self.busy = False
            self.task = None
            self.stop = None

    async def _fly_goto(self, ap: Autopilot, source: AutopilotPlace, place: PositionTarget) -> None:
        """A flight of one leg to the autopilot's place, holding there: checked as a mission
        is, flown by the same runner (its fall-back on every fault), in the autopilot's mode
        (neither set nor armed by helixd)."""
        mode = source.mode
        try:
            prepared = prepare_flight(source, self.opts.config_path, self.opts.occupancy)
        except InputsRefused as exc:
            text = "; ".join(exc.problems)
            log.error("goto_refused", mode=mode, problem=text)
            self.status.gcs.say(f"{mode}: helixd will not drive: {text}", MAV_SEVERITY_ERROR)
            return
        if self._service_stop.requested:
            return
        before = (self.status.state, self.status.detail)
        stop = self.stop = StopRequest()
        where = f"{place.lat_deg:.5f} {place.lon_deg:.5f}"  # 1 m: one line on the pane
        log.info("serve_flight_start", request=Request.GOTO.value, mode=mode, flight=self.count + 1)
        opts = run_options(prepared.flight, prepared.cfg, self.opts.run_root, self.cfg)
        host = RecordedHost(
            ap,
            stop,
            driving=Driving(mode, place, place_rule(prepared.cfg)),
            on_pause=self._held,
            disarm_when_complete=self.cfg.serve.disarm_when_complete,
            on_run_dir=partial(self._under_way, None),
        )
        runner, outcome = await self._run_flight(opts, host, f"{mode} to {where}")
        cause = outcome.cause
        summary = outcome.summary
        handed = cause in HANDED_CAUSES
        after_flight(self.auto_watch, cause, host.hold_acked_s)
        log.info("serve_flight_end", request=Request.GOTO.value, exit_code=int(outcome.exit_code))
        if handed or crew_paused(cause, stop.paused):
            self.status.set(*before, quiet=handed)  # the mission's verdict stands
        else:
            text = flight_end_text(summary, runner.numbering(), outcome.messages)
            self.status.set(ServeState.FAULTED, text, MAV_SEVERITY_ERROR)
        # ended: no run open (the interrupted mission's run, if any, stays the one to continue)
        write_state_file(self.opts.state_file, self.interrupted, self.status.state)

    async def _fly(self, ap: Autopilot, request: Request, who: str, item: int = 0) -> None:
        before = self.mission.fingerprint
        changes = self.mission.plan_changes  # before the read: an upload during it counts
        await self.read_mission(ap)  # fly what the autopilot holds now
        self._plan_changes, self._plan_change_told = changes, False
        checked = self.mission.checked
        if self.mission.read_error is not None:
            why = f"the mission could not be read ({self.mission.read_error}); start again"
            await self._refuse(ap, f"start refused: {why}")
            return
        changed = self.mission.fingerprint != before  # a plan uploaded since: the one to fly
        if checked is None:  # a new verdict was told as it was read; an old one is said again
            why = "new plan failed its checks" if changed else self.status.detail
            await self._refuse(ap, f"start refused: {why or 'no mission'}")
            return
        try:
            flight, cfg, run_root = self._flight_for(request, item)
        except InputsRefused as exc:
            text = "; ".join(exc.problems)
            log.error("serve_continue_refused", request=request.value, problem=text)
            said = "cannot continue" if request is Request.CONTINUE else "start refused"
            await self._refuse(ap, f"{said}: {text}")
            return
        if self.switch is not None and self.switch.low:
            await self._refuse(ap, "start refused: the start switch is low", MAV_SEVERITY_WARNING)
            return
        if self._service_stop.requested:
            return
        stop = self.stop = StopRequest()
        fingerprint = checked.fingerprint
        log.info("serve_flight_start", request=request.value, by=who, flight=self.count + 1)
        opts = run_options(flight, cfg, run_root, self.cfg)
        auto = request is Request.AUTO  # the autopilot runs its own item progress in AUTO
        # else the GCS highlights the item helixd flies as the autopilot's current
        shows_item = self.opts.mission_file is None and not auto
        host = RecordedHost(
            ap,
            stop,
            set_item=partial(self._set_current_item, ap) if shows_item else None,
            on_pause=self._held,
            driving=Driving(AUTO_MODE, places=place_rule(cfg)) if auto else DRIVE_MANUAL,
            disarm_when_complete=self.cfg.serve.disarm_when_complete,
            on_run_dir=partial(self._under_way, fingerprint),
        )
        what = f"the new {checked.name}" if changed else f"{request.value} by {who}"
        runner, outcome = await self._run_flight(opts, host, what)
        cause = outcome.cause
        # released to the pilot, or moved to another item: AUTO again (or still) starts
        after_flight(self.auto_watch, cause, host.hold_acked_s)
        self.item_set = cause is FaultCause.ITEM_SET
        let_go = auto and cause in HANDED_CAUSES and flight.mission.has_commands()
        self.auto_walk = None
        if let_go and outcome.run_dir is not None:
            self.auto_walk = WalkLetGo(fingerprint, flight.options, outcome.run_dir)
        state = state_after_flight(outcome.exit_code, cause, stop.paused)
        if state is ServeState.COMPLETED:
            self.interrupted = None
        elif outcome.run_dir is not None:
            self.interrupted = Interrupted(fingerprint, outcome.run_dir)
        write_state_file(self.opts.state_file, self.interrupted, state)
        if state is not ServeState.COMPLETED and self._current_item is not None:
            # ArduPilot resets its mission when disarmed outside AUTO (AP_Arming_Rover::
            # disarm): show the interrupted item again, where a continue goes on
            self._set_current_item(ap, self._current_item)
        self._current_item = None
        text = flight_end_text(outcome.summary, runner.numbering(), outcome.messages)
        severity = MAV_SEVERITY_NOTICE if state is not ServeState.FAULTED else MAV_SEVERITY_ERROR
        log.info("serve_flight_end", state=state.name.lower(), exit_code=int(outcome.exit_code))
        # handed to the next flight at once (a new place, a new item): it says where it goes
        handover = cause in NEXT_FLIGHT_CAUSES
        self.status.set(state, text, severity, quiet=handover)

    def cancel_start(self, ap: Autopilot, text: str) -> None:
        """The crew's Pause before helixd took the autopilot's AUTO (or place) as a start:
        HOLD asked as for a refused start, so that start is gone and the next is a new one."""
        task = asyncio.create_task(self._refuse(ap, text, MAV_SEVERITY_NOTICE), name="serve-hold")
        self._side_tasks.add(task)
        task.add_done_callback(self._side_tasks.discard)

    async def _refuse(self, ap: Autopilot, text: str, severity: int = MAV_SEVERITY_ERROR) -> None:
        """A start refused: the reason on the crew's screen and the rover left safe: armed in
        a mode where the autopilot drives by itself (AUTO, GUIDED: QGroundControl's Start
        Mission), HOLD is asked, so the next Start Mission (AUTO again) is a new start. Its
        acknowledgement is the AUTO watch's proof that AUTO was left: the next AUTO reported
        starts, even if no report showed the HOLD in between (:meth:`AutoWatch.left`). Were
        HOLD refused, the autopilot stays in AUTO, where Rover takes a Start Mission without a
        mode change (``Rover::set_mode`` to the mode it is in): the crew is told to leave
        AUTO first."""
        log.warning("serve_start_refused", text=text)
        self.status.gcs.say(text, severity)
        st = ap.state
        mode = crew_mode_of(st)
        if not st.armed or mode not in SELF_DRIVING_MODES:
            return
        try:
            await ap.action.set_mode(HOLD_MODE)
        except (CommandError, LinkError) as exc:
            log.error("serve_refused_hold_failed", error=str(exc))
            said = f"HOLD refused: {exc}; leave {mode}, then start"
            self.status.gcs.say(said, MAV_SEVERITY_ERROR)
            return
        self.auto_watch.left(now_s())

    async def _run_flight(
        self, opts: RunOptions, host: ServeHost, what: str
    ) -> tuple[MissionRunner, RunOutcome]:
        """One flight on the service's link: FLYING while the runner runs; its runner (for
        the operator's numbering) and outcome (its cause with it)."""
        self.count += 1
        self.status.set(ServeState.FLYING, what)
        self.busy = False
        try:  # the service idled on slow pose streams (serve.idle_pose_rate_hz)
            await host.link.pace_pose(None)
        except (CommandError, LinkError) as exc:
            log.warning("stream_pace_failed", error=str(exc), why="the flight starts on them")
        runner = MissionRunner(opts, host)
        self.runner = runner
        try:
            outcome = await runner.run()
        finally:
            self.runner = None
        self.busy = True
        return runner, outcome

    def _held(self, held: bool, mode: str) -> None:
        """The flight in progress paused by the autopilot's mode, or going on: hx_state 5, 4."""
        self.status.hold(held, f"mode {mode}")

    def _set_current_item(self, ap: Autopilot, seq: int) -> None:
        """The GCS highlights the item being flown (MAV_CMD_DO_SET_MISSION_CURRENT) while the
        autopilot holds the mission the flight read; after a new plan reached the autopilot the
        flight goes on with its own to its end, told once, and sets no item of the new one
        (its numbers are the old plan's: ArduPilot would move a DO item's to the next waypoint
        and the crew would see an item nobody flies; soak seed 3014)."""
        if self.mission.plan_changes != self._plan_changes:
            if not self._plan_change_told:
                self._plan_change_told = True
                log.info("mission_current_not_set", seq=seq, why="new_plan_on_autopilot")
                self.status.gcs.say(NEW_PLAN_TEXT, MAV_SEVERITY_NOTICE)
            self._current_item = None
            return
        self._current_item = seq

        async def send() -> None:
            try:
                await ap.action.set_mission_current(seq)
            except CommandError as exc:
                log.warning("mission_current_refused", seq=seq, error=str(exc))

        task = asyncio.create_task(send(), name="mission-current")
        self._side_tasks.add(task)
        task.add_done_callback(self._side_tasks.discard)


NEW_PLAN_TEXT = "new plan: this flight keeps its old one"  # a start flies the new


def held_walk(walk: WalkLetGo | None, fingerprint: str) -> AutoWalk | None:
    """Where the last AUTO flight of this mission was let go, while the autopilot has stayed
    armed since, from its event log: the step the autopilot's own item was on (followed along
    the walk: ``autopilot_step``, ``autopilot_item_set``), else the last step helixd started."""
    if walk is None or walk.fingerprint != fingerprint:
        return None
    options, run_dir = walk.options, walk.run_dir
    events = read_events(run_dir / EVENTS_FILE)
    step, autopilot = last_step_started(events), autopilot_step_held(events)
    exact = autopilot > 0
    log.info(
        "auto_walk_held",
        first_item=options.first_item,
        step=autopilot if exact else step,
        exact=exact,
        run_dir=str(run_dir),
    )
    return AutoWalk(options, autopilot if exact else step, exact)


def run_options(
    flight: Flight, cfg: HelixdConfig, run_root: Path, serve_cfg: HelixdConfig
) -> RunOptions:
    """A flight's options on the service's link (no terminal, no fence upload of its own)."""
    return RunOptions(
        cfg=cfg,
        mission=flight.mission,
        mission_yaml=flight.mission_yaml,
        connect_url=serve_cfg.link.url,
        run_root=run_root,
        tty=False,
        replan_from=flight.replan_from,
        inputs=with_walk(flight.inputs, flight.options),  # where a continue walks on from
        options=flight.options,
        item_numbers=flight.item_numbers,
        autopilot_fence=False,
    )


def place_rule(cfg: HelixdConfig) -> PlaceRule:
    """How a flight that follows the autopilot's mode tells the autopilot's place: the flight's
    own ``serve.target_stale_s`` and ``serve.same_place_m``."""
    return PlaceRule(cfg.serve.target_stale_s, cfg.serve.same_place_m)


def flight_end_text(summary: RunSummary | None, numbering: Numbering, messages: list[str]) -> str:
    """What the ground station reads after the state word when a flight ends: the waypoints
    reached in its own numbering (of the whole mission, as 'reached WP 3/3' counted them),
    and why a flight never started. No exit code, no result line: the fault itself went out
    when it happened."""
    if summary is None or summary.rows == 0:
        why = [m for m in messages if not m.startswith("helixd: RESULT")]
        return why[0] if why else "not flown"
    if numbering.items:  # a mission with commands: counted as flown, the item reached named
        done = f"{summary.waypoints_reached}/{summary.waypoints_total} waypoints as flown"
        if summary.patrol_item is not None:  # flown until stopped: no total
            done = f"{summary.waypoints_reached} waypoints as flown (patrol)"
        reached = [a for a in summary.arrivals if not a.via and a.number is not None]
        if reached:
            done += f", last item {reached[-1].number}/{numbering.total}"
        return done
    first = numbering.numbers[0] if numbering.numbers else 1
    return f"{first - 1 + summary.waypoints_reached}/{numbering.total} waypoints"


# -- the state file (which mission was interrupted where) ------------------------------------


def read_state_file(path: Path) -> Interrupted | None:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return None
    except (OSError, ValueError) as exc:
        log.warning("serve_state_file_unreadable", path=str(path), error=str(exc))
        return None
    fingerprint, run_dir = data.get("mission_sha256"), data.get("run_dir")
    if not isinstance(fingerprint, str) or not isinstance(run_dir, str):
        return None
    if not Path(run_dir).is_dir():
        log.warning("serve_state_run_dir_gone", path=str(path), run_dir=run_dir)
        return None
    log.info("serve_state_loaded", run_dir=run_dir, mission_sha256=fingerprint[:12])
    return Interrupted(fingerprint, Path(run_dir))


def read_open_run(path: Path) -> Path | None:
    """The run directory the state file names as under way (``open_run_dir``): a flight was
    flying when the record was written, and a record still saying so at a start means the
    service was killed before the flight ended. None: none, or unreadable."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    run_dir = data.get("open_run_dir") if isinstance(data, dict) else None
    return Path(run_dir) if isinstance(run_dir, str) and run_dir else None


def completed_run(run_dir: Path) -> bool:
    """``run_dir``'s summary says it completed (unreadable: not)."""
    try:
        data = json.loads((run_dir / SUMMARY_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(data, dict) and data.get("completed") is True


def write_state_file(
    path: Path, interrupted: Interrupted | None, state: ServeState, open_run: Path | None = None
) -> None:
    """The record (atomically replaced): the run a continue goes on from (``mission_sha256``,
    ``run_dir``), and ``open_run_dir``, the run of the flight under way (written as it starts,
    before anything is driven, cleared when it ends: still there at a start, the service was
    killed mid-flight and that run is closed then)."""
    record = {
        "state": state.name.lower(),
        "mission_sha256": None if interrupted is None else interrupted.fingerprint,
        "run_dir": None if interrupted is None else str(interrupted.run_dir.resolve()),
        "open_run_dir": None if open_run is None else str(open_run.resolve()),
        "updated_utc": datetime.now(UTC).isoformat(timespec="seconds"),
    }
    tmp = path.with_suffix(".tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp.write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
        tmp.replace(path)  # atomic: a reboot mid-write leaves the old record
    except OSError as exc:
        log.error("serve_state_file_unwritable", path=str(path), error=str(exc))


__all__ = [
    "NEW_PLAN_TEXT",
    "Flights",
    "Interrupted",
    "RecordedHost",
    "ToFly",
    "WalkLetGo",
    "after_flight",
    "completed_run",
    "flight_end_text",
    "held_walk",
    "read_open_run",
    "read_state_file",
    "run_options",
    "write_state_file",
]
