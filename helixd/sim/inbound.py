"""Handling of received MAVLink messages (pure: updates the core, queues replies).

The handler sees the core only through :class:`InboundPort`, the few reads and actions it
needs; it never imports :mod:`helixd.sim.core` nor writes the core's fields (the core builds
the handler and hands itself in as the port).

Routing as ArduPilot's MAVLink_routing::check_and_forward: a message carrying a
target_system is processed only when it is 0 (broadcast) or our sysid, and for our sysid only
when target_component is 0 or ours. Commands come back with COMMAND_ACK to the sender's
link; unknown commands → MAV_RESULT_UNSUPPORTED. MAV_CMD_DO_SET_MISSION_CURRENT goes to the
mission (helixd.sim.firmware.mission_server); what it queues (MISSION_CURRENT, jump texts)
follows the ACK, as ArduPilot's deferred ``send_message`` does. PARAM_SET answers with
PARAM_VALUE on every link (GCS::send_parameter_value); an unknown name gets no answer at all.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

from helixd.mav.constants import (
    MAV_CMD_DO_REPOSITION,
    MAV_CMD_DO_SET_MISSION_CURRENT,
    MAV_CMD_GET_MESSAGE_INTERVAL,
    MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN,
    MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES,
    MAV_CMD_REQUEST_MESSAGE,
    MAV_CMD_SET_MESSAGE_INTERVAL,
    MAV_FRAME_GLOBAL_RELATIVE_ALT,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_FAILED,
    MAV_RESULT_UNSUPPORTED,
)
from helixd.mav.ftp_wire import FtpPayloadError, from_message
from helixd.sim import stream_rates as st
from helixd.sim import vehicle_reports
from helixd.sim.firmware import messages
from helixd.sim.firmware.estimator import SimEkfStatus
from helixd.sim.firmware.messages import Message
from helixd.sim.firmware.mission_items import Outcome
from helixd.sim.firmware.mission_server import MissionServer
from helixd.sim.firmware.param_store import ParamStore
from helixd.sim.firmware.rover_firmware import SimAutopilot, SimEvent, SimStatusText

MISSION_MESSAGES = MissionServer.MESSAGES

MAVLINK_MSG_ID_SET_MODE = 11
OUR_COMPID = 1
SEVERITY_INFO = 6


def _i(msg: Message, name: str) -> int:
    return int(getattr(msg, name))


def _name(msg: Message) -> str:
    raw = getattr(msg, "param_id", b"")
    text = raw.decode("ascii", errors="replace") if isinstance(raw, bytes) else str(raw)
    return text.rstrip("\x00")


def _f(msg: Message, name: str) -> float:
    return float(getattr(msg, name))


class InboundPort(Protocol):
    """What the inbound handler reads of the simulator core and asks of it."""

    @property
    def ap(self) -> SimAutopilot: ...
    @property
    def params(self) -> ParamStore: ...
    @property
    def now_s(self) -> float: ...
    def view_now(self) -> vehicle_reports.TelemetryView: ...

    def ekf_status(self) -> SimEkfStatus: ...
    def streams(self, link: int) -> st.StreamSchedule:
        """The message-interval schedule of one link."""
        ...

    def send(self, link: int | None, msg: Message) -> None:
        """Queue a reply for one link (None: every link)."""
        ...

    def say(self, text: SimStatusText) -> None: ...
    def record(self, event: SimEvent) -> None:
        """Add an event to the simulator's log."""
        ...

    def queue_all_params(self, link: int) -> None:
        """Start streaming every parameter to ``link`` (PARAM_REQUEST_LIST)."""
        ...

    def reboot_after_replies(self) -> None:
        """Put the queued replies on the wire, then reboot the autopilot."""
        ...

    def mission_message(self, link: int, msg: Message) -> None:
        """A MISSION_* message for the mission protocol (helixd.sim.firmware.mission_server)."""
        ...

    def set_mission_current(self, link: int, param1: float, param2: float) -> tuple[int, Outcome]:
        """MAV_CMD_DO_SET_MISSION_CURRENT: (MAV_RESULT, what to send after the ACK)."""
        ...

    def reposition(self, p: list[float], is_int: bool, frame: int) -> int:
        """MAV_CMD_DO_REPOSITION: GUIDED's new place (helixd.sim.firmware.mode_goto); the
        MAV_RESULT."""
        ...

    def mission_outcome(self, out: Outcome) -> None:
        """Put a mission outcome's messages and texts on the wire, in order."""
        ...

    def ftp_request(self, link: int, payload: bytes, sysid: int, compid: int) -> None:
        """A FILE_TRANSFER_PROTOCOL payload for the autopilot's FTP server."""
        ...


class InboundHandler:
    def __init__(self, core: InboundPort) -> None:
        self.core = core
        self._handlers: dict[str, Callable[[int, Message, int, int], None]] = {
            "HEARTBEAT": self._heartbeat,
            "RC_CHANNELS_OVERRIDE": self._rc_override,
            "MANUAL_CONTROL": self._manual_control,
            "COMMAND_LONG": self._command_long,
            "COMMAND_INT": self._command_int,
            "SET_MODE": self._set_mode,
            "PARAM_REQUEST_READ": self._param_request_read,
            "PARAM_REQUEST_LIST": self._param_request_list,
            "PARAM_SET": self._param_set,
            "REQUEST_DATA_STREAM": self._request_data_stream,
            "FILE_TRANSFER_PROTOCOL": self._file_transfer,
        }
        for kind in MISSION_MESSAGES:  # GCS_MAVLINK::handle_common_mission_message
            self._handlers[kind] = self._mission

    def handle(self, link: int, msg: Message) -> None:
        kind = msg.get_type()
        handler = self._handlers.get(kind)
        if handler is None:
            return
        src_sys, src_comp = int(msg.get_srcSystem()), int(msg.get_srcComponent())
        ap = self.core.ap
        if not ap.accepts_from(src_sys):
            return
        target = getattr(msg, "target_system", None)
        if target is not None:
            if int(target) not in (0, ap.sysid()):
                return
            comp = getattr(msg, "target_component", 0)
            if int(target) != 0 and int(comp) not in (0, OUR_COMPID):
                return
        handler(link, msg, src_sys, src_comp)

    # -- simple messages -------------------------------------------------------------------

    def _heartbeat(self, link: int, msg: Message, src: int, comp: int) -> None:
        self.core.ap.on_heartbeat(src, self.core.now_s)

    def _rc_override(self, link: int, msg: Message, src: int, comp: int) -> None:
        raw = [_i(msg, f"chan{n}_raw") for n in range(1, 19)]
        self.core.ap.on_rc_override(src, raw, self.core.now_s)

    def _manual_control(self, link: int, msg: Message, src: int, comp: int) -> None:
        # GCS_MAVLINK::handle_manual_control: from the GCS sysid and aimed at us ("target"),
        # then it counts as GCS contact for the failsafe (sysid_myggcs_seen)
        ap = self.core.ap
        if ap.is_gcs(src) and _i(msg, "target") == ap.sysid():
            ap.on_gcs_contact(self.core.now_s)

    def _set_mode(self, link: int, msg: Message, src: int, comp: int) -> None:
        core = self.core
        result = core.ap.do_set_mode(
            _i(msg, "base_mode"), _i(msg, "custom_mode"), core.now_s, core.ekf_status()
        )
        core.send(link, messages.command_ack(MAVLINK_MSG_ID_SET_MODE, result, src, comp))

    # -- commands --------------------------------------------------------------------------

    def _command_long(self, link: int, msg: Message, src: int, comp: int) -> None:
        params = [_f(msg, f"param{n}") for n in range(1, 8)]
        self._command(link, _i(msg, "command"), params, src, comp)

    def _command_int(self, link: int, msg: Message, src: int, comp: int) -> None:
        params = [_f(msg, f"param{n}") for n in range(1, 5)]
        params += [float(_i(msg, "x")), float(_i(msg, "y")), _f(msg, "z")]
        frame = _i(msg, "frame")
        self._command(link, _i(msg, "command"), params, src, comp, is_int=True, frame=frame)

    def _command(
        self,
        link: int,
        command: int,
        p: list[float],
        src: int,
        comp: int,
        is_int: bool = False,
        frame: int = MAV_FRAME_GLOBAL_RELATIVE_ALT,  # a COMMAND_LONG's location: relative alt
    ) -> None:
        core = self.core
        after_ack: Outcome | None = None
        result: int | None
        if command == MAV_CMD_DO_SET_MISSION_CURRENT:
            result, after_ack = core.set_mission_current(link, p[0], p[1])
        elif command == MAV_CMD_DO_REPOSITION:
            result = core.reposition(p, is_int, frame)
        else:
            result = self._link_command(link, command, p)
        if result is None:
            result = core.ap.command(command, p, core.now_s, core.ekf_status(), is_int)
        if result is None:
            result = MAV_RESULT_UNSUPPORTED
        core.record(SimEvent("command", {"command": command, "result": result, "sysid": src}))
        core.send(link, messages.command_ack(command, result, src, comp))
        if after_ack is not None:
            core.mission_outcome(after_ack)
        if command == MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN and result == MAV_RESULT_ACCEPTED:
            core.reboot_after_replies()  # the ACK goes out before the reboot

    def _link_command(self, link: int, command: int, p: list[float]) -> int | None:
        core = self.core
        schedule = core.streams(link)
        if command == MAV_CMD_SET_MESSAGE_INTERVAL:
            msg_id = int(p[0])
            decision = st.decide_set_message_interval(
                msg_id,
                int(p[1]),
                p[2],
                core.ap.loop_rate_hz(),
                schedule.default_interval_ms(msg_id),
            )
            if decision.text:
                core.say(SimStatusText(SEVERITY_INFO, decision.text))
            if decision.interval_ms is not None:
                schedule.set_interval(msg_id, decision.interval_ms, core.now_s)
            return decision.result
        if command == MAV_CMD_GET_MESSAGE_INTERVAL:
            msg_id = int(p[0])
            if msg_id not in st.KNOWN_MESSAGES:
                core.send(link, messages.message_interval(msg_id, 0))
                return MAV_RESULT_FAILED
            interval_ms = schedule.interval_ms.get(msg_id, 0)
            core.send(link, messages.message_interval(msg_id, interval_ms * 1000 or -1))
            return MAV_RESULT_ACCEPTED
        if command == MAV_CMD_REQUEST_MESSAGE:
            msg_id = int(p[0])
            if msg_id not in st.KNOWN_MESSAGES:
                return MAV_RESULT_FAILED
            built = vehicle_reports.build(msg_id, core.view_now())
            if built is not None:
                core.send(link, built)
            return MAV_RESULT_ACCEPTED
        if command == MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
            if p[0] != 1.0:
                return MAV_RESULT_ACCEPTED
            core.send(link, messages.autopilot_version(core.ap.sysid()))
            return MAV_RESULT_ACCEPTED
        return None

    def _request_data_stream(self, link: int, msg: Message, src: int, comp: int) -> None:
        core = self.core
        core.streams(link).request_data_stream(
            _i(msg, "req_stream_id"),
            _i(msg, "req_message_rate"),
            _i(msg, "start_stop") != 0,
            core.now_s,
        )

    def _mission(self, link: int, msg: Message, src: int, comp: int) -> None:
        self.core.mission_message(link, msg)

    def _file_transfer(self, link: int, msg: Message, src: int, comp: int) -> None:
        try:
            payload = from_message(msg)
        except FtpPayloadError:
            return
        self.core.ftp_request(link, payload, src, comp)

    # -- parameters ------------------------------------------------------------------------

    def param_value_at(self, index: int) -> Message:
        params = self.core.params
        name = params.name_at(index)
        assert name is not None
        return messages.param_value(name, params.get(name), params.kind(name), len(params), index)

    def _param_request_read(self, link: int, msg: Message, src: int, comp: int) -> None:
        params = self.core.params
        index = _i(msg, "param_index")
        if index >= 0:
            if params.name_at(index) is None:
                return
        else:
            name = _name(msg)
            if name not in params:
                return  # e.g. SYSID_MYGCS on current firmware: no reply
            index = params.index(name)
        self.core.send(link, self.param_value_at(index))

    def _param_request_list(self, link: int, msg: Message, src: int, comp: int) -> None:
        self.core.queue_all_params(link)

    def _param_set(self, link: int, msg: Message, src: int, comp: int) -> None:
        core = self.core
        name = _name(msg)
        if name not in core.params:
            return
        old = core.params.get(name)
        stored = core.params.set(name, _f(msg, "param_value"))
        if stored != old:
            core.record(SimEvent("param", {"name": name, "value": stored, "old": old}))
        core.send(None, self.param_value_at(core.params.index(name)))


# ---------------------------------------------------------------------------------------------
# Forwarding between links (MAVLink_routing.cpp)

MAVLINK_MSG_ID_HEARTBEAT = 0
MAVLINK_MSG_ID_RADIO_STATUS = 109
MAVLINK_MSG_ID_ADSB_VEHICLE = 246
MAVLINK_MSG_ID_RADIO = 166
NOT_FORWARDED = frozenset({MAVLINK_MSG_ID_RADIO, MAVLINK_MSG_ID_RADIO_STATUS})


class Router:
    """ArduPilot's MAVLink_routing::check_and_forward, deciding which links get a copy.

    Routes (sysid, compid) → link are learned from every message. A HEARTBEAT goes to every
    active link (one that has received anything) except the incoming one and links that are
    known sources of that sysid/compid; RADIO/RADIO_STATUS/ADSB_VEHICLE are never forwarded;
    a message without target_system or with 0 goes to every link with a learned route except
    the incoming one; a message for another system goes where that system was seen. Our own
    sysid/compid coming back (a loop) is neither learned nor forwarded. The copy is the
    received frame unchanged (``_mavlink_resend_uart``): the sender's ids stay.
    """

    def __init__(self) -> None:
        self.routes: list[tuple[int, int, int]] = []  # (sysid, compid, link), learn order
        self.active: set[int] = set()

    def forward_links(
        self, link: int, msg: Message, own_sysid: int, own_compid: int = OUR_COMPID
    ) -> list[int]:
        sysid, compid = int(msg.get_srcSystem()), int(msg.get_srcComponent())
        self.active.add(link)
        if sysid == own_sysid and compid == own_compid:
            return []
        if sysid != 0 and (sysid, compid, link) not in self.routes:
            self.routes.append((sysid, compid, link))
        decoded: Any = msg  # a pymavlink message (the Message protocol lacks get_msgId)
        msg_id = int(decoded.get_msgId())
        if msg_id in NOT_FORWARDED or msg_id == MAVLINK_MSG_ID_ADSB_VEHICLE:
            return []
        if msg_id == MAVLINK_MSG_ID_HEARTBEAT:
            sources = {lk for s, c, lk in self.routes if (s, c) == (sysid, compid)}
            return sorted(self.active - {link} - sources)
        target_sys = int(getattr(msg, "target_system", -1))
        target_comp = int(getattr(msg, "target_component", -1))
        broadcast_sys = target_sys in (0, -1)
        broadcast_comp = target_comp in (0, -1)
        match_sys = broadcast_sys or target_sys == own_sysid
        match_comp = match_sys and (broadcast_comp or target_comp == own_compid)
        if match_sys and match_comp and not broadcast_sys and not broadcast_comp:
            return []  # only for us
        out: set[int] = set()
        for r_sys, r_comp, r_link in self.routes:
            if r_link == link:
                continue
            if broadcast_sys or (
                target_sys == r_sys and (broadcast_comp or target_comp == r_comp or not match_sys)
            ):
                out.add(r_link)
        return sorted(out)
