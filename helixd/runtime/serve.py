"""``helixd serve``: the all-day service the field crew drives from the radio and the GCS.

Phases as uvicorn's: startup (signals, sd_notify READY at once: the service is up even with no
autopilot) → the main loop (connect with backoff; on a link: heartbeats, the start switch, the
autopilot's mission watched and checked, commands answered; flights run as tasks) → shutdown
(a flight in progress is stopped through its own fall-back; the link closed).

Decisions are :mod:`helixd.runtime.serve_core`'s (pure); this module is the shell around
them. Each flight is a :class:`helixd.runtime.daemon.MissionRunner` on the service's link, so
every invariant of ``helixd run`` holds per flight: stop, release, HOLD on every ending; a
run directory per flight; nothing carried from one flight into the next but the resume
record. The service never moves the rover on its own: a flight starts only on an operator's
start (switch edge or MISSION_START), and a service (re)started by systemd comes back idle.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import time
from collections.abc import Awaitable
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import structlog
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.exitcodes import ExitCode
from helixd.base.plan import MotionMode, Numbering
from helixd.base.run_files import EVENTS_FILE
from helixd.config import HelixdConfig
from helixd.link.command_client import CommandError
from helixd.link.connection import Autopilot, MavMsg
from helixd.link.mission_transfer import MissionTransferError
from helixd.link.vehicle import PositionTarget
from helixd.mav.constants import (
    MAV_RESULT_ACCEPTED,
    MAV_SEVERITY_ERROR,
    MAV_SEVERITY_INFO,
    MAV_SEVERITY_NOTICE,
    MAV_SEVERITY_WARNING,
)
from helixd.mav.url import LinkError
from helixd.mission.expand import ExpandOptions
from helixd.mission.formats.items import GcsMission
from helixd.mission.resume import event_whole, last_step_started, with_walk
from helixd.planning.mapfile import OccupancyMap
from helixd.recorder.events import read_events
from helixd.recorder.summary import RunSummary
from helixd.runtime.autopilot_mission import (
    ground_station_mode,
    items_sha256,
)
from helixd.runtime.daemon import MissionRunner, RunOptions, RunOutcome
from helixd.runtime.flight import MANUAL_MODE
from helixd.runtime.gcs_feed import GcsFeed
from helixd.runtime.host import ServeHost
from helixd.runtime.inputs import InputsRefused
from helixd.runtime.mode_gate import AUTO_MODE, crew_mode_of, current_target_of
from helixd.runtime.notify import ServiceNotifier
from helixd.runtime.planned import Flight
from helixd.runtime.prepare import (
    AutopilotPlace,
    AutoWalk,
    Resume,
    continue_commands,
    from_autopilot_item,
    prepare_flight,
)
from helixd.runtime.serve_check import (
    CheckInputs,
    ReadyMission,
    Verdict,
    check_download,
    check_file,
)
from helixd.runtime.serve_core import (
    Answer,
    AutoWatch,
    GotoWatch,
    Request,
    ServeState,
    ServeView,
    SwitchWatch,
    answer_auto,
    answer_command,
    answer_goto,
    answer_switch,
    radio_live,
    state_after_flight,
)
from helixd.runtime.signals import StopRequest, install, uninstall
from helixd.safety.watchdogs import FaultCause

log = structlog.get_logger(__name__)
_mav = mavlink.MAVLink(None)  # encoder only: Autopilot.send_message packs with our ids

SERVE_OPTIONS = ExpandOptions(operator_continue=True)
STATE_FILE_NAME = "serve-state.json"
HX_STATE_NAME = b"hx_state"
FLIGHT_PLAN_RECEIVED = "Flight plan received"  # ArduPilot, when an upload completes
MISSION_RETRY_S = 2.0  # a failed read is tried again this soon (s), not a whole poll later


@dataclass
class ServeOptions:
    cfg: HelixdConfig
    config_path: Path | None  # hashed into each run's inputs (what a continue checks)
    run_root: Path
    mode: MotionMode | None = None  # --mode; else mission.ground_station_mode
    occupancy: OccupancyMap | None = None
    # an operator can continue a NAV_LOITER_UNLIM here (DO_PAUSE_CONTINUE 1)
    options: ExpandOptions = SERVE_OPTIONS
    mission_file: Path | None = None  # fly this file instead of the autopilot's mission

    @property
    def state_file(self) -> Path:
        return self.cfg.serve.state_file or self.run_root / STATE_FILE_NAME


class Service:
    """One ``helixd serve`` process: :meth:`run` returns only on SIGINT/SIGTERM."""

    def __init__(self, opts: ServeOptions) -> None:
        self.opts = opts
        self.cfg = opts.cfg
        self.stop = StopRequest()
        self.notifier = ServiceNotifier()
        self.state = ServeState.CONNECTING
        self.detail = ""  # the refusal, the fault, …: what the state's text says
        self.gcs = GcsFeed(self.cfg.gcs_report)
        self.switch = (
            None
            if self.cfg.startup.start_switch_channel is None
            else SwitchWatch(self.cfg.startup.start_switch_threshold_us)
        )
        self._switch_live = False  # the start switch last read from a live radio
        self.auto_watch = AutoWatch()  # the crew's start: the autopilot armed in AUTO
        # the autopilot's place in GUIDED, RTL, SMART_RTL: a flight there
        self.goto_watch = GotoWatch(self.cfg.serve.same_place_m)
        self._fence: GcsMission | None = None  # the autopilot's fence, as last downloaded
        self._autopilot_item = 0  # MISSION_CURRENT.seq: where the autopilot's AUTO runs from
        self.checked: ReadyMission | None = None
        self.fingerprint: str | None = None  # of the mission last downloaded
        self.busy = False
        self.flight_task: asyncio.Task[None] | None = None
        self.flight_stop: StopRequest | None = None
        self.runner: MissionRunner | None = None  # while a flight runs
        self.flights = 0
        self._ap: Autopilot | None = None
        self._mission_due = True
        self._mission_total: int | None = None
        self._next_poll_s = 0.0
        self._next_state_s = 0.0
        self._side_tasks: set[asyncio.Task[None]] = set()
        self._current_item: int | None = None  # the item last set as the autopilot's current
        self._interrupted = _read_state_file(opts.state_file)  # (fingerprint, run_dir) or None
        # the last AUTO flight of a mission with commands let go with the autopilot armed:
        # (fingerprint, its walk, its run directory); the autopilot keeps its jump counters
        self._auto_walk: tuple[str, ExpandOptions, Path] | None = None

    # -- state --------------------------------------------------------------------------------

    def _set_state(self, state: ServeState, detail: str = "", severity: int | None = None) -> None:
        if state is self.state and detail == self.detail:
            return
        self.state, self.detail = state, detail
        text = state.name.lower() + (f": {detail}" if detail else "")
        log.info("serve_state", state=state.name.lower(), hx_state=int(state), detail=detail)
        self.notifier.status(text)
        self.gcs.say(text, severity or MAV_SEVERITY_NOTICE)
        self._send_state()

    def _send_state(self) -> None:
        ap = self._ap
        if ap is None:
            return
        boot_ms = int(time.monotonic() * 1000) & 0xFFFFFFFF
        with contextlib.suppress(LinkError, OSError):
            ap.send_message(_mav.named_value_int_encode(boot_ms, HX_STATE_NAME, int(self.state)))
        self._next_state_s = time.monotonic() + 1.0 / self.cfg.serve.state_rate_hz

    def view(self) -> ServeView:
        resumable = (
            self._interrupted is not None
            and self.checked is not None
            and self._interrupted[0] == self.checked.fingerprint
        )
        return ServeView(
            state=self.state,
            busy=self.busy,
            refusal=self.detail if self.state in (ServeState.REFUSED, ServeState.IDLE) else "",
            resumable=resumable,
            switch_low=self.switch is not None and self.switch.low,
            last_item=0 if self.checked is None else self.checked.last_item,
            holding=self.runner is not None and self.runner.holding_forever(),
            flies_file=self.opts.mission_file is not None,
        )

    # -- the service --------------------------------------------------------------------------

    async def run(self) -> ExitCode:
        loop = asyncio.get_running_loop()
        install(loop, self.stop)
        self.notifier.ready("connecting")
        log.info("serve_start", url=self.cfg.link.url, run_root=str(self.opts.run_root))
        alive = asyncio.create_task(self._liveness(), name="serve-liveness")
        try:
            await self._main()
        except Exception:  # a bug: whatever flew was stopped by _close; systemd restarts us
            log.exception("internal_error")
            return ExitCode.INTERNAL_ERROR
        finally:
            alive.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await alive
            self.notifier.stopping("stopping")
            uninstall(loop)
            await self.gcs.close()
            self.notifier.close()
        log.info("serve_stopped", flights=self.flights)
        return ExitCode.OK

    async def _liveness(self) -> None:
        """The event loop is alive: systemd's watchdog pinged, our HEARTBEAT fed, every tick —
        also while the main loop awaits a mission download or a reconnect."""
        while True:
            self.notifier.watchdog()
            if self._ap is not None:
                self._ap.feed()
            await asyncio.sleep(self.cfg.serve.tick_s)

    async def _main(self) -> None:
        backoff_s = self.cfg.serve.reconnect_initial_s
        while not self.stop.requested:
            ap = await self._open()
            if ap is None:
                await self._pause(backoff_s)
                backoff_s = min(backoff_s * 2, self.cfg.serve.reconnect_max_s)
                continue
            backoff_s = self.cfg.serve.reconnect_initial_s
            try:
                await self._serve(ap)
            finally:
                await self._close(ap)

    async def _pause(self, seconds: float) -> None:
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(self.stop.event.wait(), seconds)

    async def _open(self) -> Autopilot | None:
        try:
            ap = await Autopilot.connect(self.cfg.link, self.cfg.safety)
        except LinkError as exc:
            if self.state is not ServeState.CONNECTING or not self.detail:
                self._set_state(ServeState.CONNECTING, f"link: {exc}", MAV_SEVERITY_WARNING)
            return None
        self._ap = ap
        ap.start_heartbeat()  # as our own component, all day
        ap.add_command_listener(self._on_command)
        ap.add_message_listener(self._on_message)
        self.gcs.start(ap.send_message)
        return ap

    async def _close(self, ap: Autopilot) -> None:
        await self._stop_flight("service stopping")
        for task in list(self._side_tasks):
            task.cancel()
        await asyncio.gather(*self._side_tasks, return_exceptions=True)
        ap.remove_command_listener(self._on_command)
        ap.remove_message_listener(self._on_message)
        ap.stop_heartbeat()
        await ap.close()
        self._ap = None

    async def _serve(self, ap: Autopilot) -> None:
        streams = False
        while not self.stop.requested:
            now = time.monotonic()
            up = ap.state.last_heartbeat_s is not None and not ap.state.link_lost
            flying = self.flight_task is not None
            if not up and not flying:
                self._set_state(ServeState.CONNECTING, "waiting for the autopilot's HEARTBEAT")
                streams = False
            elif up and not flying:
                if not streams:
                    streams = await self._streams(ap)
                    self._mission_due = True
                    if self.state is ServeState.CONNECTING:
                        self._set_state(ServeState.IDLE, "reading the autopilot's mission")
                if self._mission_due or now >= self._next_poll_s:
                    await self._read_mission(ap)
                self._watch_switch(ap)
                self._watch_auto(ap)
                self._watch_goto(ap)
            elif flying:
                self._watch_switch(ap)
                self._watch_auto(ap)
                self._watch_goto(ap)
            if now >= self._next_state_s:
                self._send_state()
            await self._pause(self.cfg.serve.tick_s)

    async def _streams(self, ap: Autopilot) -> bool:
        try:
            await ap.request_streams()
        except (CommandError, LinkError) as exc:
            log.warning("streams_request_failed", error=str(exc))
            return False
        return True

    # -- the autopilot's mission --------------------------------------------------------------

    def _on_message(self, msg: MavMsg, rx_s: float) -> None:
        kind = msg.get_type()
        if kind == "MISSION_CURRENT":
            self._autopilot_item = int(msg.seq)
            total = int(msg.total)
            if total != self._mission_total:
                if self._mission_total is not None:
                    log.info("autopilot_mission_count", total=total)
                    self._mission_due = True
                self._mission_total = total
        elif kind == "STATUSTEXT" and FLIGHT_PLAN_RECEIVED in str(msg.text):
            self._mission_due = True

    async def _read_mission(self, ap: Autopilot) -> None:
        """Download the autopilot's mission (and fence); check it when it changed."""
        self._mission_due = False
        self._next_poll_s = time.monotonic() + self.cfg.serve.mission_poll_s
        if self.opts.mission_file is not None:
            self._check_file(self.opts.mission_file)
            return
        try:
            got = await ap.mission.download()
        except (MissionTransferError, LinkError) as exc:  # e.g. a GCS uploading right now
            log.info("serve_mission_read_failed", error=str(exc))
            retry_s = min(self.cfg.serve.mission_poll_s, MISSION_RETRY_S)
            self._next_poll_s = time.monotonic() + retry_s
            return
        fingerprint = items_sha256(got.mission, got.fence)
        if fingerprint == self.fingerprint and self.state is not ServeState.IDLE:
            return
        self.fingerprint = fingerprint
        self._check(got.mission, got.fence, fingerprint)

    def _check_inputs(self) -> CheckInputs:
        o = self.opts
        return CheckInputs(self.cfg, o.config_path, o.mode, o.options, o.occupancy)

    def _check(self, mission: tuple[Any, ...], fence: tuple[Any, ...], fingerprint: str) -> None:
        """``helixd check``'s checks of the downloaded mission; the GCS is told the verdict."""
        verdict = check_download(mission, fence, fingerprint, self._check_inputs())
        if verdict.fence is not None:
            self._fence = verdict.fence  # a flight to the autopilot's place plans around it
        self._apply(verdict)

    def _check_file(self, path: Path) -> None:
        """The mission file (``serve.mission_file``, ``--mission``), checked as ``helixd run``
        checks it; the GCS is told the verdict when it changed."""
        fingerprint, verdict = check_file(path, self._check_inputs())
        if fingerprint == self.fingerprint and (verdict.checked is None or self.checked):
            return
        self.fingerprint = fingerprint
        self._apply(verdict)

    def _apply(self, verdict: Verdict) -> None:
        """A mission's verdict: READY with the checked mission, REFUSED (every problem in the
        log, the first few to the GCS) or IDLE."""
        self.checked = verdict.checked
        for p in verdict.problems:
            log.error("serve_mission_refused", problem=p)
        if verdict.state is ServeState.REFUSED:
            self._set_state(ServeState.REFUSED, verdict.detail, MAV_SEVERITY_ERROR)
            for text in verdict.more:
                self.gcs.say(text, MAV_SEVERITY_ERROR)
            return
        if verdict.checked is None:
            self._set_state(verdict.state, verdict.detail)
            return
        log.info(
            "serve_mission_checked",
            waypoints=verdict.checked.waypoints,
            fingerprint=verdict.checked.fingerprint[:12],
        )
        resume = self.view().resumable
        suffix = " (interrupted: a start continues it)" if resume else ""
        self._set_state(ServeState.READY, verdict.detail + suffix, MAV_SEVERITY_INFO)

    # -- operators ----------------------------------------------------------------------------

    def _watch_switch(self, ap: Autopilot) -> None:
        if self.switch is None:
            return
        ch = self.cfg.startup.start_switch_channel
        assert ch is not None
        st = ap.state
        live = radio_live(
            st.rc_receiver_healthy, st.rc_rx_s, time.monotonic(), self.cfg.serve.switch_stale_s
        )
        if not live:  # read only from a live radio: no edge, a veto on starting
            if self._switch_live:
                log.warning("start_switch_not_live", channel=ch, receiver=st.rc_receiver_healthy)
            self._switch_live = False
            self.switch.lost()
            return
        self._switch_live = True
        rc = st.rc_inputs_us
        edge = self.switch.update(rc[ch - 1] if len(rc) >= ch else None)
        answer = answer_switch(self.view(), edge)
        if answer is not None:
            log.info("start_switch", edge=edge.value, result=answer.result, text=answer.text)
            self._act(answer, f"start switch RC{ch}")

    def _watch_auto(self, ap: Autopilot) -> None:
        """The crew's start from the ground station: the autopilot armed in AUTO."""
        st = ap.state
        flying = self.flight_task is not None
        mode = crew_mode_of(st)
        if not st.armed and mode != AUTO_MODE:
            self._auto_walk = None  # AP_Arming_Rover::disarm resets the mission outside AUTO
        if not self.auto_watch.update(st.armed, mode, flying):
            return
        answer = answer_auto(self.view())
        if answer is None:
            return  # the mission is still being read: the start waits for the verdict
        self.auto_watch.taken()
        log.info("auto_start", item=self._autopilot_item, result=answer.result, text=answer.text)
        if answer.result != MAV_RESULT_ACCEPTED:
            self.gcs.say(answer.text, MAV_SEVERITY_ERROR)
            return
        self._act(answer, f"the autopilot's {AUTO_MODE}")

    def _watch_goto(self, ap: Autopilot) -> None:
        """The autopilot's place in GUIDED, RTL or SMART_RTL (the crew's Go to location, the
        RTL button, a failsafe): a flight there."""
        st = ap.state
        flying = self.flight_task is not None
        target = current_target_of(st, time.monotonic(), self.cfg.serve.target_stale_s)
        mode = crew_mode_of(st)  # one of GOTO_MODES whenever a place is pending
        place = self.goto_watch.update(st.armed, mode, target, flying)
        if place is None or self.busy:
            return
        self.goto_watch.taken(place)
        motion = ground_station_mode(self.cfg, self.opts.mode)
        answer = answer_goto(self.view(), mode, motion is not None)
        log.info(
            "goto_start",
            mode=mode,
            lat_deg=round(place.lat_deg, 7),
            lon_deg=round(place.lon_deg, 7),
            result=answer.result,
            text=answer.text,
        )
        if answer.result != MAV_RESULT_ACCEPTED or motion is None:
            self.gcs.say(answer.text, MAV_SEVERITY_ERROR)
            return
        source = AutopilotPlace(place.lat_deg, place.lon_deg, mode, self.cfg, motion, self._fence)
        self.busy = True  # until the flight is under way (or refused)
        self.flight_task = asyncio.create_task(
            self._flying(self._fly_goto(ap, source, place)), name="serve-goto"
        )

    def _on_command(self, msg: MavMsg, rx_s: float) -> None:
        """A COMMAND_LONG/INT addressed to helixd: answered at once (COMMAND_ACK)."""
        ap = self._ap
        if ap is None:
            return
        command = int(msg.command)
        params = (float(msg.param1), float(msg.param2))
        sender = int(msg.get_srcSystem())
        answer = answer_command(
            self.view(), command, params, sender, frozenset(self.cfg.serve.gcs_system_ids)
        )
        log.info(
            "serve_command",
            command=command,
            params=params,
            sender_sysid=sender,
            result=answer.result,
            text=answer.text,
        )
        ack = _mav.command_ack_encode(
            command, answer.result, 0, 0, sender, int(msg.get_srcComponent())
        )
        # answered from the ids it was addressed to: ours, or our component of the vehicle
        # (QGroundControl matches the COMMAND_ACK to the component it sent the command to)
        as_vehicle = int(msg.target_system) != self.cfg.link.source_system
        with contextlib.suppress(LinkError, OSError):
            if as_vehicle:
                ap.send_as_vehicle(ack)
            else:
                ap.send_message(ack)
        self._act(answer, f"system {sender}")

    def _act(self, answer: Answer, who: str) -> None:
        if answer.result != MAV_RESULT_ACCEPTED:
            if answer.text:
                self.gcs.say(answer.text, MAV_SEVERITY_WARNING)
            return
        if answer.request is Request.RELEASE:
            if self.runner is not None:
                self.runner.release_hold()
            return
        if answer.request is Request.SPEED:
            self._change_speed(answer.speed_mps, who)
            return
        if answer.request is Request.PAUSE:
            if self.flight_stop is not None:
                self.flight_stop.pause(f"{answer.text.removeprefix('pausing: ')} ({who})")
            return
        if answer.request is not None and self._ap is not None:
            self.busy = True  # until the flight is under way (or refused)
            fly = self._fly(self._ap, answer.request, who, answer.item)
            self.flight_task = asyncio.create_task(self._flying(fly), name="serve-flight")

    def _change_speed(self, asked_mps: float | None, who: str) -> None:
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
        self.gcs.say(f"speed {speed_mps:.2f} m/s{bounded}", MAV_SEVERITY_INFO)

    # -- flights ------------------------------------------------------------------------------

    def _flight_for(self, request: Request, item: int = 0) -> tuple[Flight, HelixdConfig, Path]:
        """What to fly: the checked mission from item 1 (or ``item``, FROM_ITEM), or the
        interrupted run's remainder."""
        checked = self.checked
        assert checked is not None
        if request is Request.AUTO:
            held = held_walk(self._auto_walk, checked.fingerprint)
            flight = from_autopilot_item(checked.flight, self._autopilot_item, checked.cfg, held)
            return flight, checked.cfg, self.opts.run_root
        if request is Request.FROM_ITEM:  # jump counters zero, as AP_Mission::start
            flight = from_autopilot_item(checked.flight, item, checked.cfg)
            return flight, checked.cfg, self.opts.run_root
        interrupted = self._interrupted
        if request is Request.CONTINUE and interrupted is not None:
            run_dir = interrupted[1]
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
                return flight, checked.cfg, run_dir.parent
            resumed = prepare_flight(Resume(run_dir), self.opts.config_path)
            for note in resumed.notes:
                log.info("serve_resume", note=note)
            cfg = resumed.cfg.model_copy(update={"link": self.cfg.link})
            return resumed.flight, cfg, run_dir.parent
        return checked.flight, checked.cfg, self.opts.run_root

    async def _flying(self, flight: Awaitable[None]) -> None:
        """A flight task: whatever ends it, the service is free for the next."""
        try:
            await flight
        finally:
            self.busy = False
            self.flight_task = None
            self.flight_stop = None

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
            self.gcs.say(f"{mode}: helixd will not drive: {text}", MAV_SEVERITY_ERROR)
            return
        if self.stop.requested:
            return
        before = (self.state, self.detail)
        stop = self.flight_stop = StopRequest()
        where = f"{place.lat_deg:.7f} {place.lon_deg:.7f}"
        log.info(
            "serve_flight_start", request=Request.GOTO.value, mode=mode, flight=self.flights + 1
        )
        opts = _run_options(prepared.flight, prepared.cfg, self.opts.run_root, self.cfg)
        host = ServeHost(ap, stop, driving_mode=mode, goto=place)
        runner, outcome, cause = await self._run_flight(opts, host, f"{mode} to {where}")
        summary = outcome.summary
        handed = cause in (FaultCause.RELEASED, FaultCause.ITEM_SET, FaultCause.HANDOVER)
        self.auto_watch.flight_ended(left_auto=handed)
        log.info("serve_flight_end", request=Request.GOTO.value, exit_code=int(outcome.exit_code))
        if handed or cause is FaultCause.PAUSED or stop.paused:
            self._set_state(*before)  # the mission's verdict stands
            return
        text = flight_end_text(summary, runner.numbering(), outcome.messages)
        self._set_state(ServeState.FAULTED, text, MAV_SEVERITY_ERROR)

    async def _fly(self, ap: Autopilot, request: Request, who: str, item: int = 0) -> None:
        before = self.fingerprint
        await self._read_mission(ap)  # fly what the autopilot holds now
        if self.checked is None or self.fingerprint != before:
            self.gcs.say("start refused: the mission changed; checked it again", MAV_SEVERITY_ERROR)
            return
        try:
            flight, cfg, run_root = self._flight_for(request, item)
        except InputsRefused as exc:
            text = "; ".join(exc.problems)
            log.error("serve_continue_refused", request=request.value, problem=text)
            said = "cannot continue" if request is Request.CONTINUE else "start refused"
            self.gcs.say(f"{said}: {text}", MAV_SEVERITY_ERROR)
            return
        if self.switch is not None and self.switch.low:
            self.gcs.say("start refused: the start switch is low", MAV_SEVERITY_WARNING)
            return
        if self.stop.requested:
            return
        stop = self.flight_stop = StopRequest()
        fingerprint = self.checked.fingerprint
        log.info("serve_flight_start", request=request.value, by=who, flight=self.flights + 1)
        opts = _run_options(flight, cfg, run_root, self.cfg)
        auto = request is Request.AUTO  # the autopilot runs its own item progress in AUTO
        # else the GCS highlights the item helixd flies as the autopilot's current
        shows_item = self.opts.mission_file is None and not auto
        host = ServeHost(
            ap,
            stop,
            set_item=self._set_current_item if shows_item else None,
            driving_mode=AUTO_MODE if auto else MANUAL_MODE,
        )
        runner, outcome, cause = await self._run_flight(opts, host, f"{request.value} by {who}")
        summary = outcome.summary
        # released to the pilot, or moved to another item: AUTO again (or still) starts
        handed = (FaultCause.RELEASED, FaultCause.ITEM_SET, FaultCause.HANDOVER)
        self.auto_watch.flight_ended(left_auto=cause in handed)
        let_go = auto and cause in handed and flight.mission.has_commands()
        self._auto_walk = None
        if let_go and outcome.run_dir is not None:
            self._auto_walk = (fingerprint, flight.options, outcome.run_dir)
        state = state_after_flight(outcome.exit_code, cause, stop.paused)
        if state is ServeState.COMPLETED:
            self._interrupted = None
        elif outcome.run_dir is not None:
            self._interrupted = (fingerprint, outcome.run_dir)
        _write_state_file(self.opts.state_file, self._interrupted, state)
        if state is not ServeState.COMPLETED and self._current_item is not None:
            # ArduPilot resets its mission when disarmed outside AUTO (AP_Arming_Rover::
            # disarm): show the interrupted item again, where a continue goes on
            self._set_current_item(self._current_item)
        self._current_item = None
        text = flight_end_text(summary, runner.numbering(), outcome.messages)
        severity = MAV_SEVERITY_NOTICE if state is not ServeState.FAULTED else MAV_SEVERITY_ERROR
        log.info("serve_flight_end", state=state.name.lower(), exit_code=int(outcome.exit_code))
        self._set_state(state, text, severity)

    async def _run_flight(
        self, opts: RunOptions, host: ServeHost, what: str
    ) -> tuple[MissionRunner, RunOutcome, FaultCause | None]:
        """One flight on the service's link: FLYING while the runner runs; its runner (for
        the operator's numbering), outcome and cause."""
        self.flights += 1
        self._set_state(ServeState.FLYING, what)
        self.busy = False
        runner = MissionRunner(opts, host)
        self.runner = runner
        try:
            outcome = await runner.run()
        finally:
            self.runner = None
        self.busy = True
        summary = outcome.summary
        return runner, outcome, _cause(summary.fault if summary is not None else None)

    def _set_current_item(self, seq: int) -> None:
        """The GCS highlights the item being flown (MAV_CMD_DO_SET_MISSION_CURRENT)."""
        ap = self._ap
        if ap is None:
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

    async def _stop_flight(self, why: str) -> None:
        task, stop = self.flight_task, self.flight_stop
        if task is None:
            return
        if stop is not None:
            stop.trigger(why)
        await asyncio.gather(task, return_exceptions=True)


def held_walk(walk: tuple[str, ExpandOptions, Path] | None, fingerprint: str) -> AutoWalk | None:
    """Where the last AUTO flight of this mission was let go, while the autopilot has stayed
    armed since, from its event log: the step the autopilot's own item was on (followed along
    the walk: ``autopilot_step``, ``autopilot_item_set``), else the last step helixd started."""
    if walk is None or walk[0] != fingerprint:
        return None
    _, options, run_dir = walk
    events = read_events(run_dir / EVENTS_FILE)
    step, autopilot = last_step_started(events), 0
    for ev in events:
        name = ev.get("event")
        if name == "autopilot_step":
            autopilot = event_whole(ev.get("step"), autopilot)
        elif name == "autopilot_item_set":
            autopilot = event_whole(ev.get("autopilot_step"), autopilot)
    exact = autopilot > 0
    log.info(
        "auto_walk_held",
        first_item=options.first_item,
        step=autopilot if exact else step,
        exact=exact,
        run_dir=str(run_dir),
    )
    return AutoWalk(options, autopilot if exact else step, exact)


def _run_options(
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


def _cause(fault_text: str | None) -> FaultCause | None:
    """The fault cause a summary's ``fault`` ("cause: detail") starts with."""
    from_text = (fault_text or "").split(":", 1)[0]
    return next((c for c in FaultCause if c.value == from_text), None)


# -- the state file (which mission was interrupted where) ------------------------------------


def _read_state_file(path: Path) -> tuple[str, Path] | None:
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
    return fingerprint, Path(run_dir)


def _write_state_file(path: Path, interrupted: tuple[str, Path] | None, state: ServeState) -> None:
    record = {
        "state": state.name.lower(),
        "mission_sha256": None if interrupted is None else interrupted[0],
        "run_dir": None if interrupted is None else str(interrupted[1].resolve()),
        "updated_utc": datetime.now(UTC).isoformat(timespec="seconds"),
    }
    tmp = path.with_suffix(".tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp.write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
        tmp.replace(path)  # atomic: a reboot mid-write leaves the old record
    except OSError as exc:
        log.error("serve_state_file_unwritable", path=str(path), error=str(exc))


async def serve(opts: ServeOptions) -> ExitCode:
    return await Service(opts).run()


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
