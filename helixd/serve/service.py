"""``helixd serve``: the all-day service the field crew drives from the radio and the GCS.

Phases as uvicorn's: startup (signals, sd_notify READY at once: the service is up even with no
autopilot) → the main loop (connect with backoff; on a link: heartbeats, the start switch, the
autopilot's mission watched and checked, commands answered; flights run as tasks) → shutdown
(a flight in progress is stopped through its own fall-back; the link closed).

Decisions are :mod:`helixd.serve.core`'s (pure); this module is the shell around
them, with its parts: the state told to the crew (:mod:`~helixd.serve.status`), the
mission watched (:mod:`~helixd.serve.mission`) and the flights
(:mod:`~helixd.serve.flights`). Each flight is a
:class:`helixd.runtime.daemon.MissionRunner` on the service's link, so every invariant of
``helixd run`` holds per flight: stop, release, HOLD on every ending; a run directory per
flight; nothing carried from one flight into the next but the resume record. The service
never moves the rover on its own: a flight starts only on an operator's start (switch edge,
MISSION_START, the autopilot armed in AUTO, or its place in GUIDED, RTL, SMART_RTL), and a
service (re)started by systemd comes back idle.
"""

from __future__ import annotations

import asyncio
import contextlib

import structlog
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.clock import now_s
from helixd.base.exitcodes import ExitCode
from helixd.link.connection import Autopilot, MavMsg
from helixd.link.services.command_client import CommandError
from helixd.link.services.preflight import check_obedience
from helixd.mav.constants import (
    MAV_RESULT_ACCEPTED,
    MAV_SEVERITY_ERROR,
    MAV_SEVERITY_WARNING,
)
from helixd.mav.url import LinkError, heartbeat_wait_text
from helixd.prepare.autopilot_mission import ground_station_mode
from helixd.prepare.builder import AutopilotPlace
from helixd.report.gcs_feed import GcsFeed
from helixd.report.notify import ServiceNotifier
from helixd.runtime.mode_gate import AUTO_MODE, crew_mode_of, crew_mode_rx_s, current_target_of
from helixd.runtime.signals import StopRequest, install, uninstall
from helixd.safety.supervisor import HOLD_MODE
from helixd.serve.core import (
    Answer,
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
)
from helixd.serve.flights import SELF_DRIVING_MODES, Flights
from helixd.serve.mission import MissionWatch
from helixd.serve.options import ServeOptions
from helixd.serve.status import ServeStatus

log = structlog.get_logger(__name__)
_mav = mavlink.MAVLink(None)  # encoder only: Autopilot.send_message packs with our ids


class Service:
    """One ``helixd serve`` process: :meth:`run` returns only on SIGINT/SIGTERM."""

    def __init__(self, opts: ServeOptions) -> None:
        self.opts = opts
        self.cfg = opts.cfg
        self.stop = StopRequest()
        self.notifier = ServiceNotifier()
        self.gcs = GcsFeed(self.cfg.gcs_report)
        self.status = ServeStatus(self.cfg, self.notifier, self.gcs)
        self.switch = (
            None
            if self.cfg.startup.start_switch_channel is None
            else SwitchWatch(self.cfg.startup.start_switch_threshold_us)
        )
        self._switch_live = False  # the start switch last read from a live radio
        # the autopilot's place in GUIDED, RTL, SMART_RTL: a flight there
        self.goto_watch = GotoWatch(self.cfg.serve.same_place_m)
        self.mission = MissionWatch(opts)
        self.flights = Flights(opts, self.mission, self.status, self.switch, self.stop)
        self._ap: Autopilot | None = None
        self._warm: asyncio.Task[None] | None = None  # the parameters read while idle
        self._reboots = 0  # the autopilot's reboots seen: its parameters read again after one

    def view(self) -> ServeView:
        state, checked = self.status.state, self.mission.checked
        return ServeView(
            state=state,
            busy=self.flights.busy,
            refusal=self.status.detail if state in (ServeState.REFUSED, ServeState.IDLE) else "",
            resumable=self.flights.resumable(checked),
            switch_low=self.switch is not None and self.switch.low,
            last_item=0 if checked is None else checked.last_item,
            holding=self.flights.holding(),
            flies_file=self.opts.mission_file is not None,
            self_driving=self._self_driving(),
        )

    def _self_driving(self) -> bool:
        """No flight, and the autopilot armed in a mode where it drives by itself."""
        ap = self._ap
        if ap is None or self.flights.flying:
            return False
        return ap.state.armed and crew_mode_of(ap.state) in SELF_DRIVING_MODES

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
        log.info("serve_stopped", flights=self.flights.count)
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
            status = self.status
            if status.state is not ServeState.CONNECTING or not status.detail:
                status.set(ServeState.CONNECTING, f"link: {exc}", MAV_SEVERITY_WARNING)
            return None
        self._ap = self.status.ap = ap
        ap.start_heartbeat()  # as our own component, all day
        ap.param.keep_cache()  # a start judges what was read while idle (and PARAM_VALUE since)
        ap.add_command_listener(self._on_command)
        ap.add_message_listener(self.mission.on_message)
        self.gcs.start(ap.send_message)
        cut = self.flights.take_cut_text()  # the flight the service's kill cut: told once
        if cut is not None:
            self.gcs.say(cut, MAV_SEVERITY_WARNING)
        return ap

    async def _close(self, ap: Autopilot) -> None:
        await self.flights.close("service stopping")
        await self._cool()
        ap.remove_command_listener(self._on_command)
        ap.remove_message_listener(self.mission.on_message)
        ap.stop_heartbeat()
        await ap.close()
        self._ap = self.status.ap = None

    async def _serve(self, ap: Autopilot) -> None:
        streams = False
        while not self.stop.requested:
            now = now_s()
            up = ap.state.last_heartbeat_s is not None and not ap.state.link_lost
            flying = self.flights.flying
            if not up and not flying:
                link = self.cfg.link
                self.status.set(ServeState.CONNECTING, heartbeat_wait_text(link.url, link.baud))
                streams = False
                await self._cool()  # what a rebooted or another autopilot holds is read anew
            elif up and not flying:
                if ap.state.reboot_count != self._reboots:
                    self._reboots = ap.state.reboot_count
                    await self._cool()
                if not streams:
                    streams = await self._streams(ap)
                    self.mission.due = True
                if streams and self._warm is None:
                    self._warm = asyncio.create_task(self._warm_params(ap), name="serve-params")
                    if self.status.state is ServeState.CONNECTING:
                        self.status.set(ServeState.IDLE, "reading the autopilot's mission")
                if self.mission.read_due(now):
                    await self.flights.read_mission(ap)
                if streams and not self.flights.flying:
                    await self._pace_pose(ap, self._idle_pose_hz(ap))
            if up or flying:
                self._watch_switch(ap)
                self._watch_auto(ap)
                self._watch_goto(ap)
            if self.status.due(now):
                self.status.send()
            await self._pause(self.cfg.serve.tick_s)

    async def _warm_params(self, ap: Autopilot) -> None:
        """While idle: read the parameters a start's preflight judges, into the link's cache
        (kept fresh by PARAM_VALUE; a missing one remembered), so a start reads none."""
        t0 = now_s()
        try:
            problems = await check_obedience(ap, self.cfg.actuation, self.cfg.link)
        except (CommandError, LinkError) as exc:
            log.info("params_warm_failed", error=str(exc))
            return
        cache = ap.param.cache
        log.info(
            "params_warm",
            seconds=round(now_s() - t0, 3),
            known=0 if cache is None else len(cache.values),
            missing=[] if cache is None else sorted(cache.missing),
            problems=len(problems),  # judged again, and told, at a start's preflight
        )

    async def _cool(self) -> None:
        """The parameters forgotten (and their idle read stopped): read again when next up."""
        task, self._warm = self._warm, None
        if task is not None:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
        ap = self._ap
        if ap is not None and ap.param.cache is not None:
            ap.param.cache.forget()

    def _idle_pose_hz(self, ap: Autopilot) -> float | None:
        """Slow pose streams (serve.idle_pose_rate_hz) between flights while disarmed or
        holding (armed in HOLD); the flight's rate (None) while armed in another mode (the
        autopilot's own drive, the pilot's). Each flight asks it back before it starts."""
        st = ap.state
        if st.armed and st.mode != HOLD_MODE:
            return None
        return self.cfg.serve.idle_pose_rate_hz or None

    @staticmethod
    async def _pace_pose(ap: Autopilot, rate_hz: float | None) -> None:
        try:
            await ap.pace_pose(rate_hz)
        except (CommandError, LinkError) as exc:
            log.info("stream_pace_failed", error=str(exc))

    async def _streams(self, ap: Autopilot) -> bool:
        try:
            await ap.request_streams()
        except (CommandError, LinkError) as exc:
            log.warning("streams_request_failed", error=str(exc))
            return False
        return True

    # -- operators ----------------------------------------------------------------------------

    def _watch_switch(self, ap: Autopilot) -> None:
        if self.switch is None:
            return
        ch = self.cfg.startup.start_switch_channel
        assert ch is not None
        st = ap.state
        live = radio_live(
            st.rc_receiver_healthy, st.rc_rx_s, now_s(), self.cfg.serve.switch_stale_s
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
        mode = crew_mode_of(st)
        if not st.armed and mode != AUTO_MODE:
            self.flights.auto_walk = None  # AP_Arming_Rover::disarm resets it outside AUTO
        flying = self.flights.flying
        auto_watch = self.flights.auto_watch
        if not auto_watch.update(st.armed, mode, flying, crew_mode_rx_s(st)):
            return
        answer = answer_auto(self.view())
        if answer is None:
            return  # the mission is still being read: the start waits for the verdict
        auto_watch.taken()
        item = self.mission.autopilot_item
        log.info("auto_start", item=item, result=answer.result, text=answer.text)
        if answer.result != MAV_RESULT_ACCEPTED:
            self.gcs.say(answer.text, MAV_SEVERITY_ERROR)
            return
        self._act(answer, f"the autopilot's {AUTO_MODE}")

    def _watch_goto(self, ap: Autopilot) -> None:
        """The autopilot's place in GUIDED, RTL or SMART_RTL (the crew's Go to location, the
        RTL button, a failsafe): a flight there."""
        st = ap.state
        target = current_target_of(st, now_s(), self.cfg.serve.target_stale_s)
        mode = crew_mode_of(st)  # one of GOTO_MODES whenever a place is pending
        place = self.goto_watch.update(st.armed, mode, target, self.flights.flying)
        if place is None or self.flights.busy:
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
        fence = self.mission.fence
        source = AutopilotPlace(place.lat_deg, place.lon_deg, mode, self.cfg, motion, fence)
        self.flights.start_goto(ap, source, place)

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
            self.flights.release_hold()
        elif answer.request is Request.SPEED:
            self.flights.change_speed(answer.speed_mps, who)
        elif answer.request is Request.PAUSE:
            self.flights.pause(f"{answer.reason} ({who})")
        elif answer.request is Request.HOLD and self._ap is not None:
            self.flights.cancel_start(self._ap, answer.text)
        elif answer.request is not None and self._ap is not None:
            self.flights.start(self._ap, answer.request, who, answer.item)


async def serve(opts: ServeOptions) -> ExitCode:
    return await Service(opts).run()


__all__ = ["Service", "serve"]
