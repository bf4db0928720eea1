"""The simulator's functional core: autopilot + physics + estimator + faults, stepped in
simulated time, MAVLink messages in and out as plain objects. No sockets, no clocks; the
random generator is passed in. :mod:`helixd.sim.server` is the I/O shell around it.
"""

from __future__ import annotations

import dataclasses
import math
from collections import deque
from collections.abc import Mapping
from types import MappingProxyType
from typing import Protocol

import numpy as np

from helixd.base.frames import latlon_to_ne, ne_to_latlon
from helixd.base.media import Medium
from helixd.mav.constants import (
    MAV_CMD_NAV_WAYPOINT,
    MAV_FRAME_GLOBAL,
    MAV_FRAME_GLOBAL_INT,
    MAV_MISSION_ACCEPTED,
    MAV_MISSION_ERROR,
    MAV_MISSION_TYPE_MISSION,
    MAV_MISSION_TYPE_RALLY,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_FAILED,
)
from helixd.mav.guard_script import SCR_ENABLE
from helixd.plant import collisions, physics, skid
from helixd.plant.ground import TerrainTraction
from helixd.plant.plant_config import Plant
from helixd.plant.sonar import sense, water_temperature_c
from helixd.plant.state import PhysicsState
from helixd.plant.world import bathymetry_ne, media_ne
from helixd.sim import stream_rates as st
from helixd.sim import vehicle_reports
from helixd.sim.faults import FaultClock, FaultError, FaultSpec, make_spec
from helixd.sim.firmware import estimator, messages
from helixd.sim.firmware.messages import (
    STATUSTEXT_LEN,
    Message,
    file_transfer_protocol,
    statustexts,
)
from helixd.sim.firmware.mission_items import (
    ALTITUDE_ONLY,
    GuidedRequest,
    Outcome,
    guided_request,
    mission_ack,
)
from helixd.sim.firmware.mission_server import MissionServer
from helixd.sim.firmware.mode_auto import ModeAuto
from helixd.sim.firmware.mode_goto import (
    ModeGoto,
    Place,
    SmartRtlPath,
    reposition_refusal,
    rtl_destination,
)
from helixd.sim.firmware.modes import MODE_NUMBERS
from helixd.sim.firmware.param_store import ParamStore
from helixd.sim.firmware.rover_firmware import (
    ScriptReader,
    SimAutopilot,
    SimEvent,
    SimStatusText,
    no_scripts,
)
from helixd.sim.inbound import InboundHandler
from helixd.sim.sim_config import SimConfig

SONAR_MESSAGES = frozenset({st.MSG_DISTANCE_SENSOR, st.MSG_RANGEFINDER})
PARAMS_PER_LOOP = 2  # PARAM_REQUEST_LIST streaming pace (ArduPilot rate-limits it too)
# a quiet autopilot (SimCore.quiet_steps) takes at most this many loops in one step: its 10 Hz
# checks (failsafes, the guard's) still run every tenth of a second at 50 Hz
QUIET_STEPS_MAX = 5
REST_EPS = 1e-6  # body speeds (m/s, rad/s) and scroll speeds (rad/s) below this are at rest
# a PWM in the middle of each mode-switch position (RC_Channel::read_mode_switch bands)
SWITCH_POSITION_PWM_US = (1100, 1295, 1425, 1555, 1685, 1900)


class FtpHandler(Protocol):
    """The autopilot's MAVLink FTP server (helixd.sim.ftp_server.FtpServer over its working
    directory)."""

    def handle(
        self, payload: bytes, *, sysid: int, compid: int, now_s: float, link: int = 0
    ) -> list[bytes]: ...


class LinkState:
    def __init__(self, default_rate_hz: float, loop_rate_hz: int) -> None:
        self.streams = st.StreamSchedule(default_rate_hz, loop_rate_hz)
        self.param_queue: deque[int] = deque()


class SimCore:
    """``ftp``: the FTP server that answers FILE_TRANSFER_PROTOCOL (None: not answered);
    ``scripts``: reads the scripts directory when the autopilot boots (the shell's I/O)."""

    def __init__(
        self,
        config: SimConfig,
        n_links: int,
        rng: np.random.Generator,
        *,
        ftp: FtpHandler | None = None,
        scripts: ScriptReader = no_scripts,
    ) -> None:
        self.config = config
        self.rng = rng
        params = dict(config.params)
        if config.guard_installed:
            params[SCR_ENABLE] = 1.0
        self.params = ParamStore(params, stored=config.guard_params)
        self._ftp = ftp
        self.ap = SimAutopilot(config, self.params, 0.0, scripts)
        self._was_armed = False  # for the mission reset on disarm
        self.links = [self._new_link() for _ in range(n_links)]
        self.faults = FaultClock()
        self._gps_lost_since_s: float | None = None  # fault gps_loss, simulated time
        # fault gps_receiver_silent: (since, simulated time; the last fix then)
        self._gps_stopped: tuple[float, vehicle_reports.GpsHeld] | None = None
        self.pending: list[tuple[float, FaultSpec]] = []
        self.outbox: list[tuple[int | None, Message]] = []
        self.flushed: list[tuple[int | None, Message]] = []  # resolved, sent even if now silent
        self.events: list[SimEvent] = []
        self.phys = config.start_state()
        self.est = estimator.EstimatorState()
        self._contact = False  # rover body touching an obstacle (helixd.plant.collisions)
        self.motor = config.motor_map()
        self.outputs_us: list[int] = [0] * 16
        # the world's media by place (helix plant): the map placed around the EKF origin, and
        # the medium under each of scrolls 1..4 after the last step (None: no map)
        self.media_ne = media_ne(config)
        self.scroll_media: tuple[Medium, ...] | None = None
        # the pose the media under the scrolls were last looked up at, and what they were
        # (the map never changes: the same pose has the same media)
        self._media_looked_up: tuple[tuple[float, float, float], tuple[Medium, ...]] | None = None
        # the pond's bottom and the sonar over it (helixd.plant.sonar), with a generator of its
        # own so a bathymetry changes nothing else a seed gives
        self.bathy = bathymetry_ne(config)
        self.sonar_rng = np.random.default_rng(None if config.seed is None else [config.seed, 55])
        self._next_named_value_s = 0.0
        self.now_s = 0.0
        self._epoch_s = 0.0
        self._n = 0
        self._chunk_id = 0
        self._origin_sent = False
        self._touched = True  # an input since the last loop: the next is one loop (quiet_steps)
        self.inbound = InboundHandler(self)
        self.mission = MissionServer(
            config.origin_lat_deg,
            config.origin_lon_deg,
            config.origin_alt_m,
            requires_mission=lambda: self.ap.mode == MODE_NUMBERS["AUTO"],
        )
        self.ap.mission_present = lambda: len(self.mission.stored()) > 1
        self.auto = ModeAuto()
        self.goto = ModeGoto()  # GUIDED's, RTL's and SmartRTL's place (firmware.mode_goto)
        self.srtl = SmartRtlPath()  # AP_SmartRTL's saved path
        self.ap.smart_rtl_ready = lambda: self.srtl.active
        self.ap.on_disarm = self._mission_on_disarm
        self._mode_before = self.ap.mode  # a mode entered or left: AUTO's, GUIDED's, RTL's
        self._params_view: tuple[int, Mapping[str, float]] = (-1, MappingProxyType({}))
        self.view = self._view(self.ekf_status(), self.now_s)

    # -- bookkeeping -----------------------------------------------------------------------

    def _new_link(self) -> LinkState:
        return LinkState(self.config.default_stream_rate_hz, self.ap.loop_rate_hz())

    def params_view(self) -> Mapping[str, float]:
        """Read-only copy of the parameters, rebuilt only when one changed."""
        if self._params_view[0] != self.params.version:
            self._params_view = (self.params.version, MappingProxyType(self.params.as_dict()))
        return self._params_view[1]

    def dt_s(self) -> float:
        return 1.0 / self.ap.loop_rate_hz()

    def link_up(self, link: int) -> bool:
        if self.ap.silent(self.now_s):
            return False
        if self.faults.on("link_drop"):
            which = self.faults.args["link_drop"].get("link")
            return which is not None and int(str(which)) != link
        return True

    def send(self, link: int | None, msg: Message) -> None:
        self.outbox.append((link, msg))

    def say(self, text: SimStatusText) -> None:
        if len(text.text) > STATUSTEXT_LEN:  # only chunked texts take a fresh id (never 0)
            self._chunk_id = self._chunk_id % 65535 + 1
        for m in statustexts(text.severity, text.text, self._chunk_id):
            self.send(text.link, m)
        self.events.append(SimEvent("statustext", {"severity": text.severity, "text": text.text}))

    # -- the inbound handler's port (helixd.sim.inbound.InboundPort) -------------------------

    def streams(self, link: int) -> st.StreamSchedule:
        return self.links[link].streams

    def record(self, event: SimEvent) -> None:
        self.events.append(event)

    def queue_all_params(self, link: int) -> None:
        self.links[link].param_queue = deque(range(len(self.params)))

    def reboot_after_replies(self) -> None:
        # drain first: drain_outbox replaces self.flushed, so ``self.flushed.extend(
        # self.drain_outbox())`` extended the old list and lost the reboot's COMMAND_ACK
        resolved = self.drain_outbox()
        self.flushed.extend(resolved)
        self.inject(make_spec("reboot", {}))

    def mission_message(self, link: int, msg: Message) -> None:
        guided = guided_request(msg)
        if guided is None:
            self.mission_outcome(self.mission.handle(link, msg, self.now_s))
            return
        who = (int(msg.get_srcSystem()), int(msg.get_srcComponent()))
        self.send(link, mission_ack(who, self.guided_item(guided), MAV_MISSION_TYPE_MISSION))

    def guided_item(self, req: GuidedRequest) -> int:
        """A guided place as a MISSION_ITEM (``handle_guided_request``: taken only in GUIDED,
        ``ModeGuided::set_desired_location``) or an altitude change (nothing on a rover); the
        MAV_MISSION_RESULT."""
        if req.result != MAV_MISSION_ACCEPTED or req.item is None:
            return req.result
        if req.current == ALTITUDE_ONLY:
            return MAV_MISSION_ACCEPTED
        if self.ap.mode != MODE_NUMBERS["GUIDED"]:
            return MAV_MISSION_ERROR
        item = req.item
        amsl = item.frame in (MAV_FRAME_GLOBAL, MAV_FRAME_GLOBAL_INT)
        alt_m = item.z if amsl else self.config.origin_alt_m + item.z
        self.goto.go(self._place(item.x, item.y, alt_m), self.ap.here_ne, rtl=False)
        return MAV_MISSION_ACCEPTED

    def set_mission_current(self, link: int, param1: float, param2: float) -> tuple[int, Outcome]:
        return self.mission.do_set_mission_current(link, param1, param2)

    def reposition(self, p: list[float], is_int: bool, frame: int) -> int:
        """MAV_CMD_DO_REPOSITION (:mod:`helixd.sim.firmware.mode_goto`): GUIDED's new place,
        switching to GUIDED when param2 asks; the MAV_RESULT."""
        guided = MODE_NUMBERS["GUIDED"]
        lat_e7, lon_e7 = (
            (int(p[4]), int(p[5])) if is_int else (round(p[4] * 1e7), round(p[5] * 1e7))
        )
        refusal = reposition_refusal(self.ap.mode == guided, p[1], lat_e7, lon_e7, frame, p[6])
        if refusal is not None:
            return refusal
        if self.ap.mode != guided:
            if not self.ap.set_mode(guided, "gcs_command", self.now_s, self.ekf_status()):
                return MAV_RESULT_FAILED
            self._mode_changed()
        if p[0] > 0.0 and self.ap.change_speed(1.0, p[0]) != MAV_RESULT_ACCEPTED:
            return MAV_RESULT_FAILED
        amsl = frame in (MAV_FRAME_GLOBAL, MAV_FRAME_GLOBAL_INT)
        alt_m = p[6] if amsl else self.config.origin_alt_m + p[6]
        self.goto.go(self._place(lat_e7, lon_e7, alt_m), self.ap.here_ne, rtl=False)
        return MAV_RESULT_ACCEPTED

    def _place(self, lat_e7: int, lon_e7: int, alt_amsl_m: float) -> Place:
        cfg = self.config
        ne = latlon_to_ne(lat_e7 / 1e7, lon_e7 / 1e7, cfg.origin_lat_deg, cfg.origin_lon_deg)
        return Place(ne, lat_e7, lon_e7, alt_amsl_m)

    def ftp_request(self, link: int, payload: bytes, sysid: int, compid: int) -> None:
        """GCS_FTP: each reply goes back to the sender on the link the request came in on."""
        if self._ftp is None:
            return
        for reply in self._ftp.handle(
            payload, sysid=sysid, compid=compid, now_s=self.now_s, link=link
        ):
            self.send(link, file_transfer_protocol(reply, sysid, compid))

    def mission_outcome(self, out: Outcome) -> None:
        for step in out.steps:
            if isinstance(step, SimStatusText):
                self.say(step)
            else:
                self.send(*step)

    def drain_outbox(self) -> list[tuple[int | None, Message]]:
        """Messages to put on the wire; a link that is down (dropped/silent) loses its share."""
        out, self.outbox = self.outbox, []
        result, self.flushed = self.flushed, []
        for link, msg in out:
            if link is None:
                for i in range(len(self.links)):
                    if self.link_up(i):
                        result.append((i, msg))
            elif self.link_up(link):
                result.append((link, msg))
        return result

    def drain_events(self) -> list[SimEvent]:
        self._collect()
        out, self.events = self.events, []
        return out

    def _collect(self) -> None:
        self.events.extend(self.ap.events)
        self.ap.events.clear()
        texts, self.ap.texts = self.ap.texts, []
        for text in texts:
            if self.ap.silent(self.now_s):
                continue
            self.say(text)

    # -- faults and the pilot --------------------------------------------------------------

    def schedule(self, spec: FaultSpec, at_s: float) -> None:
        self._touched = True
        self.pending.append((at_s, spec))
        self.pending.sort(key=lambda p: p[0])

    def inject(self, spec: FaultSpec) -> None:
        self._touched = True
        now = self.now_s
        kw = spec.kwargs
        switch_pwm = self._switch_pwm(str(kw["mode"])) if spec.name == "pilot_takeover" else 0
        self.events.append(SimEvent("fault", {"name": spec.name, **kw}))
        if spec.name == "reboot":
            silent = kw.get("silent_s")
            silent_s = self.config.reboot_silent_s if silent is None else float(str(silent))
            self.ap.reboot(now, silent_s)
            self.mission.reboot()
            self.links = [self._new_link() for _ in self.links]
            self._epoch_s, self._n = now, 0
            self._origin_sent = False
        elif spec.name == "gps_jump":
            bearing = math.radians(float(str(kw["bearing_deg"])))
            distance_m, variance = float(str(kw["distance_m"])), float(str(kw["variance"]))
            self.est = estimator.gps_jump(self.est, distance_m, bearing, variance)
        elif spec.name == "pilot_takeover":
            self.set_rc(self.params.get_int("MODE_CH"), switch_pwm)
        elif spec.name == "battery_low":
            self.ap.battery_low(
                now,
                self.ekf_status(),
                float(str(kw["voltage_v"])),
                float(str(kw["used_mah"])),
                bool(kw["critical"]),
            )
            self._collect()  # the text leaves before the HEARTBEAT with the new mode
        elif spec.name == "fence_breach":
            ap = self.ap
            if ap.fence_breach(now, self.ekf_status()):
                self.send(None, messages.fence_status(ap.fence_breach_count, ap.fence_breach_ms))
            self._collect()
        else:
            self.faults.start(spec, now)
            if spec.name == "rc_loss" and kw.get("kind") == "failsafe_values":
                self.ap.set_receiver_failsafe_values(True)
            elif spec.name == "rc_loss":
                self.ap.set_receiver_ok(False)
            elif spec.name == "gps_loss":
                self._gps_lost_since_s = now
            elif spec.name == "gps_receiver_silent":
                north_m, east_m = estimator.gps_fix(self.est, self.phys)
                held = vehicle_reports.GpsHeld(self.ap.time_boot_ms(now), north_m, east_m)
                self._gps_stopped = (now, held)

    def _switch_pwm(self, mode: str) -> int:
        number = MODE_NUMBERS.get(mode.upper())
        if number is None:
            raise FaultError(f"pilot_takeover: unknown mode {mode!r}")
        for position in range(6):
            if self.params.get_int(f"MODE{position + 1}") == number:
                return SWITCH_POSITION_PWM_US[position]
        raise FaultError(f"pilot_takeover: no MODE1..MODE6 switch position is {mode}")

    def clear_fault(self, name: str) -> None:
        if self.faults.clear(name):
            self._fault_ended(name)

    def _fault_ended(self, name: str) -> None:
        self.events.append(SimEvent("fault_end", {"name": name}))
        if name == "rc_loss":
            self.ap.set_receiver_ok(True)
            self.ap.set_receiver_failsafe_values(False)
        elif name == "gps_loss":
            self._gps_lost_since_s = None
        elif name == "gps_receiver_silent":
            self._gps_stopped = None

    def set_rc(self, channel: int, pwm_us: int) -> None:
        if not 1 <= channel <= 16:
            raise ValueError(f"RC channel must be 1..16, got {channel}")
        self._touched = True
        self.ap.set_pilot_rc(channel, pwm_us)
        self.events.append(SimEvent("pilot_rc", {"channel": channel, "pwm_us": pwm_us}))

    # -- the loop --------------------------------------------------------------------------

    def ekf_status(self) -> estimator.SimEkfStatus:
        return estimator.ekf_status(
            self.est,
            self.config.noise_profile(),
            self.ap.origin_set(self.now_s) and not self.ap.booting(self.now_s),
            self.faults.on("ekf_unhealthy")
            or self._gps_lost_for(self.config.gps_dead_reckon_s)
            or self._gps_stopped_for(self.config.gps_dead_reckon_s),
        )

    def _gps_lost_for(self, at_least_s: float) -> bool:
        """The gps_loss fault has lasted ``at_least_s`` (simulated seconds)."""
        since = self._gps_lost_since_s
        return since is not None and self.now_s - since >= at_least_s

    def _gps_stopped_for(self, at_least_s: float) -> bool:
        """The gps_receiver_silent fault has lasted ``at_least_s`` (simulated seconds)."""
        stopped = self._gps_stopped
        return stopped is not None and self.now_s - stopped[0] >= at_least_s

    def _gps_held(self) -> vehicle_reports.GpsHeld | None:
        """What GPS_RAW_INT repeats while the receiver is silent (None: it is not)."""
        if self._gps_stopped is None:
            return None
        held = self._gps_stopped[1]
        if self._gps_stopped_for(self.config.gps_receiver_timeout_s):
            return dataclasses.replace(held, no_gps=True)
        return held

    def handle(self, link: int, msg: Message) -> None:
        # a HEARTBEAT only stamps its sender's time (the GCS failsafe's, checked at 10 Hz)
        self._touched = self._touched or msg.get_type() != "HEARTBEAT"
        if self.link_up(link):
            self.inbound.handle(link, msg)
            self._collect()

    def quiet_steps(self) -> int:
        """How many loops the next step may take at once (1: every loop its own): more only
        while nothing moves or changes with time but the clocks of the streams — booted,
        disarmed or holding (armed in HOLD), at rest, no fault on or scheduled, no input
        since the last loop — and no message is due before the step's end (each message
        still leaves in the loop it is due in), at most :data:`QUIET_STEPS_MAX`. A shell on
        a simulated clock steps so."""
        ap, ph, now = self.ap, self.phys, self.now_s
        driving_mode = ap.armed and ap.mode != MODE_NUMBERS["HOLD"]  # HOLD: outputs at trim
        if self._touched or driving_mode or ap.booting(now) or self.pending or self.faults.active:
            return 1
        for speed in (ph.vx_body_mps, ph.vy_body_mps, ph.wz_body_radps, *ph.scroll_radps):
            if abs(speed) >= REST_EPS:  # moving
                return 1
        if self.param_queued():
            return 1
        due_s = min(link.streams.next_due_s() for link in self.links)
        if self.bathy is not None and self.config.sonar.named_value:
            due_s = min(due_s, self._next_named_value_s)
        steps = int((due_s - now) / self.dt_s() + 1e-9)
        return max(1, min(QUIET_STEPS_MAX, steps))

    def param_queued(self) -> bool:
        return any(link.param_queue for link in self.links)

    def tick(self, steps: int = 1) -> None:
        """``steps`` loops in one (more than one only as :meth:`quiet_steps` allows)."""
        self._touched = False
        self._n += steps
        now = self._epoch_s + self._n * self.dt_s()
        dt_s = steps * self.dt_s()
        self.now_s = now
        while self.pending and self.pending[0][0] <= now:
            self.inject(self.pending.pop(0)[1])
        for name in self.faults.expire(now):
            self._fault_ended(name)
        ekf = self.ekf_status()
        outputs = self.ap.step(now, ekf)
        self._collect()
        for i, (old, new) in enumerate(zip(self.outputs_us, outputs, strict=True)):
            if old != new:
                self.events.append(SimEvent("output", {"channel": i + 1, "pwm_us": new}))
        self.outputs_us = outputs
        self.phys, self._contact, contact = collisions.contact_step(
            self.config.obstacles, self.phys, self._plant_step(outputs, dt_s), self._contact
        )
        if contact is not None:
            self.events.append(SimEvent(*contact))
        self.est = estimator.step(self.est, dt_s, self.config.noise_profile(), self.rng)
        here = estimator.estimate(self.est, self.phys)
        self.ap.observe_position(
            now, here.north_m, here.east_m, self.ap.origin_set(now) and not self.ap.booting(now)
        )
        self._collect()
        self.view = self._view(ekf, now)
        if self.ap.home_changed and not self.ap.silent(now):
            # AP_AHRS::set_home pushes MSG_HOME and MSG_ORIGIN; a push already pending this
            # loop (the origin just set, sent below) goes out once (GCS_MAVLINK's bitmask)
            self.ap.home_changed = False
            pushed = [st.MSG_HOME_POSITION]
            if self._origin_sent:
                pushed.append(st.MSG_GPS_GLOBAL_ORIGIN)
            for msg_id in pushed:
                built = vehicle_reports.build(msg_id, self.view)
                if built is not None:
                    self.send(None, built)
        self._smart_rtl_save(arming=self.ap.armed and not self._was_armed)
        self._was_armed = self.ap.armed
        self._mode_changed()
        self._mode_auto(now)
        if self.goto.place is not None:
            radius_m = self.params.get("WP_RADIUS")
            self.mission_outcome(self.goto.update(self.ap.here_ne, radius_m))
        self.mission_outcome(self.mission.update(now))
        self._telemetry(now)

    def _mode_changed(self) -> None:
        """A mode entered or left: AUTO's (ModeAuto::_enter; ``_exit`` stops the mission),
        GUIDED's Stop submode, RTL's place (:mod:`helixd.sim.firmware.mode_goto`)."""
        auto = MODE_NUMBERS["AUTO"]
        mode = self.ap.mode
        if mode == self._mode_before:
            return
        if self._mode_before == auto:
            self.mission.stop()
        if mode == auto:
            self.auto.enter()
        self.goto.stop()
        home = self.ap.home
        if mode == MODE_NUMBERS["RTL"] and home is not None:
            alt_m = self.config.origin_alt_m
            home_place = self._place(round(home.lat_deg * 1e7), round(home.lon_deg * 1e7), alt_m)
            rally = [
                self._place(item.x, item.y, alt_m + item.z)
                for item in self.mission.stored(MAV_MISSION_TYPE_RALLY)
            ]
            here = self.ap.here_ne or home_place.ne
            self.goto.go(rtl_destination(here, home_place, rally), here, rtl=True)
        if mode == MODE_NUMBERS["SMART_RTL"]:
            self.mission_outcome(self.goto.follow(self.srtl.points, self.ap.here_ne))
        self._mode_before = mode

    def _smart_rtl_save(self, arming: bool) -> None:
        """AP_SmartRTL: the path from the first position and from each arming
        (``set_home``), a point every SRTL_ACCURACY outside SmartRTL (``save_position``)."""
        here = self.ap.here_ne
        if here is None:
            return
        restart = arming or not self.srtl.active
        if not restart and (self.ap.mode == MODE_NUMBERS["SMART_RTL"] or not self.srtl.due(here)):
            return
        cfg = self.config
        lat, lon = ne_to_latlon(*here, cfg.origin_lat_deg, cfg.origin_lon_deg)
        place = Place(here, round(lat * 1e7), round(lon * 1e7), cfg.origin_alt_m)
        if restart:
            self.srtl.set_home(place)
        else:
            self.srtl.points.append(place)

    def _position_target(self) -> tuple[int, int, float] | None:
        """The mode's place to go (get_desired_location): AUTO's current waypoint, GUIDED's
        or RTL's place; None in the other modes."""
        if self.ap.mode != MODE_NUMBERS["AUTO"]:
            return self.goto.published()
        current = self.mission.nav_item()
        if current is None or current[1].command != MAV_CMD_NAV_WAYPOINT:
            return None
        item = current[1]
        return (item.x, item.y, self.config.origin_alt_m + item.z)

    def _mode_auto(self, now: float) -> None:
        """AUTO running: the mission verified against the EKF's position
        (:mod:`helixd.sim.firmware.mode_auto`)."""
        if self.ap.mode != MODE_NUMBERS["AUTO"]:
            return
        cfg = self.config
        origin = (
            (cfg.origin_lat_deg, cfg.origin_lon_deg)
            if self.ap.origin_set(now) and not self.ap.booting(now)
            else None
        )
        radius_m = self.params.get("WP_RADIUS")
        self.mission_outcome(self.auto.update(self.mission, self.ap.here_ne, origin, radius_m))

    def _plant_step(self, outputs: list[int], dt: float) -> PhysicsState:
        cfg = self.config
        stalled = self.faults.on("stall")
        if cfg.plant is Plant.SITL_SKID:
            m = cfg.skid
            return skid.step(
                self.phys,
                dt,
                outputs[skid.LEFT_OUTPUT - 1],
                outputs[skid.RIGHT_OUTPUT - 1],
                max_speed_mps=m.max_speed_mps,
                max_accel_mss=m.max_accel_mss,
                turn_rate_dps=m.turn_rate_dps,
                max_yaw_rate_dps=m.max_yaw_rate_dps,
                physics_rate_hz=m.physics_rate_hz,
                stalled=stalled,
            )
        fractions = physics.scroll_fractions_from_pwm(
            outputs, cfg.scroll_output_channels, cfg.scroll_reversed, self.motor
        )
        traction = cfg.traction() if self.media_ne is None else self._scroll_tractions()
        return physics.step(
            self.phys,
            dt,
            fractions,
            cfg.vehicle,
            traction,
            cfg.motor_time_constant_s,
            stalled=stalled,
        )

    def _scroll_tractions(self) -> tuple[TerrainTraction, ...]:
        """The traction under each scroll where it is now; a change is a ``media`` event."""
        assert self.media_ne is not None
        ph, cfg = self.phys, self.config
        pose = (ph.north_m, ph.east_m, ph.yaw_ned_rad)
        looked_up = self._media_looked_up
        if looked_up is not None and looked_up[0] == pose:  # at rest: the same place again
            media = looked_up[1]
        else:
            where = physics.scroll_positions_ne(*pose, cfg.vehicle)
            media = tuple(self.media_ne.medium_at(n, e) for n, e in where)
            self._media_looked_up = (pose, media)
        if media != self.scroll_media:
            self.scroll_media = media
            self.events.append(SimEvent("media", {"scrolls": [m.value for m in media]}))
        return tuple(cfg.terrains.get(m) for m in media)

    def _view(self, ekf: estimator.SimEkfStatus, now: float) -> vehicle_reports.TelemetryView:
        ap, cfg = self.ap, self.config
        gps_n, gps_e = estimator.gps_fix(self.est, self.phys)
        profile = cfg.noise_profile()
        return vehicle_reports.TelemetryView(
            time_boot_ms=ap.time_boot_ms(now),
            mode=ap.mode,
            armed=ap.armed,
            booting=ap.booting(now),
            failsafe_active=bool(ap.failsafes.triggered) or ap.failsafes.ekf_failsafe,
            origin_set=ap.origin_set(now),
            home_set=ap.home_set(now),
            prearm_ok=not ap.booting(now) and not ap.prearm_failures(now, ekf),
            rc_ok=not ap.failsafes.radio_on(),  # rc().in_rc_failsafe(), not the receiver
            estimate=estimator.estimate(self.est, self.phys),
            gps_north_m=gps_n,
            gps_east_m=gps_e,
            gps_accuracy_m=profile.pos_sigma_m + profile.pos_white_m,
            truth=self.phys,
            ekf=ekf,
            radio_in_us=tuple(ap.rc.radio_in_us),
            outputs_us=tuple(self.outputs_us),
            origin_lat_deg=cfg.origin_lat_deg,
            origin_lon_deg=cfg.origin_lon_deg,
            origin_alt_m=cfg.origin_alt_m,
            sysid=ap.sysid(),
            home=None
            if ap.home is None
            else (ap.home.lat_deg, ap.home.lon_deg, ap.home.north_m, ap.home.east_m),
            relay_masks=ap.payload.relay_status(self.params),
            mission_current=self.mission.mission_current_fields(),
            gps_lost=self._gps_lost_for(cfg.gps_loss_report_s),
            gps_held=self._gps_held(),
            fence=ap.fence_breached if self.params.get_int("FENCE_ENABLE") else None,
            battery_failsafe=ap.battery_failsafe_level > 0,
            position_target=self._position_target(),
        )

    def _mission_on_disarm(self) -> None:
        """AP_Arming_Rover::disarm: outside AUTO the mission is reset, at the disarm itself,
        so MISSION_CURRENT reads 0 until something sets the current item again (a current
        item set after the disarm stays)."""
        if self.ap.mode != MODE_NUMBERS["AUTO"]:
            self.mission.reset_on_disarm()

    def view_now(self) -> vehicle_reports.TelemetryView:
        """The last tick's view with what a command handled since may have changed (mode,
        arming, the mission's current item): ArduPilot builds a requested message when it
        sends it, from its state then, so a HEARTBEAT asked for after a mode change never
        names the mode before (nor follows a MISSION_CURRENT that told the new one)."""
        ap = self.ap
        return dataclasses.replace(
            self.view,
            mode=ap.mode,
            armed=ap.armed,
            mission_current=self.mission.mission_current_fields(),
        )

    def _telemetry(self, now: float) -> None:
        if self.ap.silent(now):
            return
        view = self.view
        if view.origin_set and not self._origin_sent:
            self._origin_sent = True
            origin = vehicle_reports.build(st.MSG_GPS_GLOBAL_ORIGIN, view)
            if origin is not None:
                self.send(None, origin)
        hidden: set[int] = set()
        if self.faults.on("stale_pose"):
            hidden |= vehicle_reports.POSE_MESSAGES
            if self.faults.args["stale_pose"].get("attitude"):
                hidden.add(st.MSG_ATTITUDE)
        if self.faults.on("gps_silent"):
            hidden.add(st.MSG_GPS_RAW_INT)
        sonar: list[Message | None] = []  # this tick's reading, sensed once for every link
        for i, link in enumerate(self.links):
            for msg_id in link.streams.due(now):
                if msg_id in hidden or (view.booting and msg_id != st.MSG_HEARTBEAT):
                    continue
                if msg_id in SONAR_MESSAGES:
                    msg = self._sonar_message(msg_id, view, sonar)
                else:
                    msg = vehicle_reports.build(msg_id, view, self.faults)
                if msg is not None:
                    self.send(i, msg)
            for _ in range(PARAMS_PER_LOOP):
                if not link.param_queue:
                    break
                self.send(i, self.inbound.param_value_at(link.param_queue.popleft()))
        self._named_value(now, view)

    def _depth_here(self) -> float | None:
        """The true depth under the rover's centre (None: dry, or no bathymetry)."""
        if self.bathy is None:
            return None
        return self.bathy.depth_at(self.phys.north_m, self.phys.east_m)

    def _sonar_message(
        self, msg_id: int, view: vehicle_reports.TelemetryView, sensed: list[Message | None]
    ) -> Message | None:
        """DISTANCE_SENSOR / RANGEFINDER from the sonar (:mod:`helixd.plant.sonar`); None
        without a bathymetry (no rangefinder), before the EKF origin, or on a dropout."""
        if self.bathy is None or not view.origin_set:
            return None
        if not sensed:
            reading = sense(self._depth_here(), self.config.sonar, self.sonar_rng)
            sensed.append(
                None
                if reading is None
                else messages.distance_sensor(view.time_boot_ms, *reading.cm(), reading.quality_pct)
            )
            sensed.append(None if reading is None else messages.rangefinder(reading.distance_m))
        return sensed[0] if msg_id == st.MSG_DISTANCE_SENSOR else sensed[1]

    def _named_value(self, now: float, view: vehicle_reports.TelemetryView) -> None:
        """The payload's NAMED_VALUE_FLOAT (a script's, at its own rate) over water."""
        sonar = self.config.sonar
        if self.bathy is None or not sonar.named_value or now < self._next_named_value_s:
            return
        self._next_named_value_s = now + 1.0 / sonar.named_value_rate_hz
        depth = self._depth_here()
        if depth is not None and view.origin_set and not view.booting:
            value = water_temperature_c(depth, self.sonar_rng)
            self.send(None, messages.named_value_float(view.time_boot_ms, sonar.named_value, value))
