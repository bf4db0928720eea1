"""The MAVLink link: the :class:`Autopilot` facade the daemon uses, over the plumbing
(:mod:`helixd.link.wire.transport`, :mod:`helixd.link.wire.codec`,
:mod:`helixd.link.wire.heartbeat`) and with its plugins (:mod:`helixd.link.telemetry`,
:mod:`helixd.link.services.action`, :mod:`helixd.link.services.param`,
:mod:`helixd.link.services.mission_link` and :mod:`helixd.link.services.ftp_link`, attached in
:meth:`Autopilot.__init__`).

Reading never blocks the event loop: every transport is a non-blocking file descriptor watched
with ``loop.add_reader`` (UDP socket, TCP socket, or a termios-configured serial device). The
reader callback drains the descriptor until it would block, parses, filters and dispatches in
the loop thread — no thread hand-over, no extra wake-up. Measured with
``tools/bench_link_latency.py`` (sendto in another process → handler, loopback UDP, shared
2-core box): p50 50–80 µs, p99 270–340 µs, idle or with a busy control loop, against
p50 75–90 µs and a busy-loop p99 450–500 µs for a reader thread handing messages over with
``call_soon_threadsafe``, at 10–20 % less CPU per message. Draining before any woken coroutine
runs also keeps already-queued duplicate COMMAND_ACKs away from the next command
(see :mod:`helixd.link.services.command_client`).

Writes never block either: UDP ``sendto`` on a non-blocking socket (a full buffer drops the
datagram, as the network would), TCP/serial through a bounded write buffer flushed with
``loop.add_writer``.

Reconnect: a serial device that vanishes (read error / EOF) or a TCP peer that closes is
reopened every ``reconnect_interval_s`` without restarting the process. A UDP link has nothing
to reopen; HEARTBEAT silence (``safety.heartbeat_timeout_s``) marks it lost instead, and
``time_boot_ms`` going backwards marks an autopilot reboot. Either way ``state.link_lost`` /
``state.link_lost_count`` (and ``state.reboot_count``) say so, and the message streams are
requested again once HEARTBEATs return.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Coroutine
from typing import Any

import structlog
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.clock import now_s
from helixd.config.link import LinkConfig
from helixd.config.safety import SafetyConfig
from helixd.link.limits import LinkLimits, link_limits
from helixd.link.services.action import Action
from helixd.link.services.command_client import AckStats, CommandClient, CommandError
from helixd.link.services.ftp_link import FtpClient
from helixd.link.services.mission_link import MissionClient
from helixd.link.services.param import Param
from helixd.link.statustext import AssembledText, StatusTextAssembler
from helixd.link.streams import StreamManager
from helixd.link.telemetry import ChangeWaiters, Telemetry
from helixd.link.vehicle import Change, VehicleState
from helixd.link.wire.codec import LinkEvents, LinkStats, MavlinkConnection, NeverSent
from helixd.link.wire.heartbeat import HeartbeatSender
from helixd.link.wire.ownid import OwnIdSenders
from helixd.link.wire.signing import load_signing_key
from helixd.link.wire.tlog import LinkTlog
from helixd.mav.constants import (
    GCS_CONTACT_MESSAGE_IDS,
    MAV_CMD_REQUEST_MESSAGE,
    MAV_STATE_BOOT,
    MAVLINK_MSG_ID_HEARTBEAT,
)
from helixd.mav.url import LinkTimeout, LinkUrl, parse_link_url

__all__ = [
    "Autopilot",
]

log = structlog.get_logger(__name__)

MavMsg = Any


# ---------------------------------------------------------------------------------------------
# The facade


def no_heartbeat_text(
    cfg: LinkConfig, url: LinkUrl, stats: LinkStats, st: VehicleState, timeout_s: float
) -> str:
    """Why we might not have heard the autopilot, from what we did hear."""
    hints: list[str] = []
    if st.foreign_sysid_counts:
        heard = ", ".join(f"{s} ({n} msgs)" for s, n in sorted(st.foreign_sysid_counts.items()))
        hints.append(f"heard other systems {heard}: set link.target_system")
    if stats.signature_rejects:
        hints.append(f"{stats.signature_rejects} messages failed the signing check")
    if stats.bad_data and not stats.rx_messages:
        hints.append(f"{stats.bad_data} chunks of non-MAVLink data (wrong baud?)")
    if stats.unknown_messages:
        hints.append(
            f"{stats.unknown_messages} messages with ids unknown to the ardupilotmega dialect"
        )
    if not hints:
        hints.append("nothing received at all")
    return (
        f"no HEARTBEAT from system {cfg.target_system} on {url.text} within "
        f"{timeout_s:g} s; " + "; ".join(hints)
    )


# changes that are logged (and re-request the streams): rare, checked with one test per message
_NOTABLE_CHANGES = Change.REBOOT | Change.LINK_REGAINED | Change.MODE | Change.ARMED


class Autopilot:
    """One autopilot over one link, holding its plugins as MAVSDK's ``System`` does.

    Plugins: :attr:`telemetry` (:mod:`helixd.link.telemetry`: ``async for pose in
    ap.telemetry.pose()``, ``ap.telemetry.next_pose(...)``), :attr:`action`
    (:mod:`helixd.link.services.action`: arm, disarm, mode, RC override, servo, any COMMAND_LONG),
    :attr:`param` (:mod:`helixd.link.services.param`), :attr:`mission`
    (:mod:`helixd.link.services.mission_link`: ``ap.mission.download()``,
    ``ap.mission.upload(...)``) and :attr:`ftp` (:mod:`helixd.link.services.ftp_link`:
    ``ap.ftp.run(exchange)``); callers use them directly. The facade itself owns the link: the
    vehicle state (:attr:`state`), heartbeats, stream negotiation, raw messages, the link log and
    closing. Nothing here decides to stop the rover.
    """

    def __init__(
        self,
        cfg: LinkConfig,
        limits: SafetyConfig | LinkLimits,
        url: LinkUrl,
        signing_key: bytes | None,
        *,
        observer: bool = False,
    ) -> None:
        self.observer = observer
        if observer:
            cfg = cfg.model_copy(update={"source_system": cfg.observer_system})
        self.cfg = cfg
        self.limits = link_limits(limits)
        self.url = url
        self.state = VehicleState(
            ekf_variance_max=self.limits.ekf_variance_max,
            pose_stale_s=self.limits.pose_stale_s,
            reboot_backstep_ms=round(cfg.reboot_backstep_s * 1000),
            target_component=cfg.target_component,
            statustext_history=cfg.statustext_history,
            bounds=self.limits.bounds,
        )
        events = LinkEvents(
            self._on_message,
            self._on_foreign,
            self._on_transport_lost,
            self._on_reopened,
            self._on_addressed,
        )
        never_send = GCS_CONTACT_MESSAGE_IDS if observer else frozenset()
        self._conn = MavlinkConnection(cfg, url, signing_key, events, never_send=never_send)
        self._commands = CommandClient(lambda: self._conn.mav, self._conn.send, cfg, self.state)
        self._heartbeat = HeartbeatSender(self._conn, cfg)
        self._texts = StatusTextAssembler(cfg.statustext_timeout_s)
        self._waiters = ChangeWaiters()
        self._listeners: list[Callable[[MavMsg, float], None]] = []
        self._command_listeners: list[Callable[[MavMsg, float], None]] = []
        self.telemetry = Telemetry(
            self.state, self._waiters, self.add_message_listener, self.remove_message_listener
        )
        self.action = Action(cfg, self.state, self._commands, self._waiters, self._conn)
        self.param = Param(self._commands)
        self.mission = MissionClient(self, self.send_message)
        self.ftp = FtpClient(self)
        self._streams = StreamManager(self.action.command_long, cfg, self.param.get)
        self._tasks: set[asyncio.Task[None]] = set()
        self._rerequest: asyncio.Task[None] | None = None
        self._monitoring = False  # streams requested: the housekeeping tick checks their rates

    # -- lifecycle ----------------------------------------------------------------------------

    @classmethod
    async def connect(
        cls, cfg: LinkConfig, limits: SafetyConfig | LinkLimits, *, observer: bool = False
    ) -> Autopilot:
        """Open the link and start reading; LinkError (one human message) if it cannot.

        ``limits``: the link's few safety numbers (:mod:`helixd.link.limits`); a
        ``SafetyConfig`` is read for them.

        ``observer``: for every command that does not fly. It speaks as
        ``link.observer_system``, not as the GCS id, and never sends what ArduPilot counts as
        contact with its GCS (:data:`helixd.mav.constants.GCS_CONTACT_MESSAGE_IDS`: HEARTBEAT,
        RC_CHANNELS_OVERRIDE, MANUAL_CONTROL — refused with
        :class:`helixd.link.wire.codec.NeverSent`), so the autopilot's GCS failsafe neither counts
        on it nor fires after it closes.
        """
        url = parse_link_url(cfg.url, cfg.baud)
        key = load_signing_key(cfg.signing_key_file) if cfg.signing_key_file else None
        ap = cls(cfg, limits, url, key, observer=observer)
        await ap._conn.open()
        ap._spawn(ap._housekeeping(), "link_housekeeping")
        return ap

    async def close(self) -> None:
        self._heartbeat.stop()
        tasks = list(self._tasks)
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        self._waiters.release_all()
        await self._conn.close()
        log.info("link_closed", url=self.url.text, stats=vars(self._conn.stats))

    def _spawn(self, coro: Coroutine[Any, Any, None], name: str) -> asyncio.Task[None]:
        task = asyncio.get_running_loop().create_task(coro, name=name)
        self._tasks.add(task)
        task.add_done_callback(self._task_done)
        return task

    def _task_done(self, task: asyncio.Task[None]) -> None:
        self._tasks.discard(task)
        if not task.cancelled() and task.exception() is not None:
            log.error("link_task_failed", task=task.get_name(), error=repr(task.exception()))

    @property
    def local_address(self) -> tuple[str, int] | None:
        """Where a udpin link listens (useful with port 0)."""
        return self._conn.transport.local_address

    @property
    def link_stats(self) -> LinkStats:
        return self._conn.stats

    @property
    def own_id_senders(self) -> OwnIdSenders:
        """Other senders using our system id (see :mod:`helixd.link.wire.ownid`)."""
        return self._conn.own_id_senders

    def own_id_watch_s(self) -> float:
        """How long the autopilot has known us (since our first message) — 0 before that.

        ArduPilot forwards another link's HEARTBEATs to ours only once ours is active, i.e.
        after it received something from us.
        """
        first = self._conn.first_tx_s
        return 0.0 if first is None else now_s() - first

    @property
    def ack_stats(self) -> AckStats:
        return self._commands.stats

    @property
    def granted_rates_hz(self) -> dict[str, float]:
        return self._streams.granted_hz

    def add_message_listener(self, callback: Callable[[MavMsg, float], None]) -> None:
        """``callback(msg, rx_monotonic_s)`` for every message of the autopilot's system."""
        self._listeners.append(callback)

    def remove_message_listener(self, callback: Callable[[MavMsg, float], None]) -> None:
        self._listeners.remove(callback)

    def add_command_listener(self, callback: Callable[[MavMsg, float], None]) -> None:
        """``callback(msg, rx_monotonic_s)`` for every COMMAND_LONG / COMMAND_INT another
        system (a ground station, routed by the autopilot) addresses to our system and
        component; the listener answers it (COMMAND_ACK). Without a listener such commands
        are dropped as any other system's messages are."""
        self._command_listeners.append(callback)

    def remove_command_listener(self, callback: Callable[[MavMsg, float], None]) -> None:
        self._command_listeners.remove(callback)

    # -- reader side --------------------------------------------------------------------------

    def _on_addressed(self, msg: MavMsg, rx_s: float) -> None:
        for callback in self._command_listeners:
            callback(msg, rx_s)

    def _on_message(self, msg: MavMsg, rx_s: float) -> None:
        mtype = msg.get_type()
        if mtype == "STATUSTEXT":
            changes = self._statustext_chunk(msg, rx_s)
        else:
            changes = self.state.apply(msg, rx_s)
            if self._texts.pending:
                changes |= self._expired_texts(rx_s)
        self._commands.on_message(msg, rx_s)
        self._streams.monitor.record(mtype)
        if changes:
            self._on_changes(changes)
        for callback in self._listeners:
            callback(msg, rx_s)

    def _statustext_chunk(self, msg: MavMsg, rx_s: float) -> int:
        """Feed one STATUSTEXT to the reassembler; the state sees whole texts only."""
        texts = self._texts.add(
            int(msg.get_srcSystem()),
            int(msg.get_srcComponent()),
            int(msg.severity),
            str(msg.text),
            int(getattr(msg, "id", 0) or 0),
            int(getattr(msg, "chunk_seq", 0) or 0),
            rx_s,
        )
        return self._apply_texts(texts, rx_s)

    def _expired_texts(self, now_s: float) -> int:
        if not self._texts.pending:
            return Change.NONE
        return self._apply_texts(self._texts.expire(now_s), now_s)

    def _apply_texts(self, texts: list[AssembledText], rx_s: float) -> int:
        changes = Change.NONE
        for text in texts:
            whole = mavlink.MAVLink_statustext_message(text.severity, b"", 0, 0)
            whole.text = text.text  # may be longer than one frame's 50 characters
            changes |= self.state.apply(whole, rx_s)
            if text.complete:
                log.info("autopilot_statustext", text=text.text, severity=text.severity)
            else:
                log.info(
                    "autopilot_statustext",
                    text=text.text,
                    severity=text.severity,
                    incomplete=True,
                    chunks=text.chunks,
                )
        return changes

    def _on_changes(self, changes: int) -> None:
        if changes & _NOTABLE_CHANGES:
            self._log_changes(changes)
        self._waiters.wake(changes)
        if changes & Change.POSE and self.state.pose is not None:
            self.telemetry.pose_read(self.state.pose)  # the control step, in this wake-up

    def _log_changes(self, changes: int) -> None:
        st = self.state
        if changes & Change.REBOOT:
            log.warning(
                "autopilot_rebooted", reboots=st.reboot_count, time_boot_ms=st.last_time_boot_ms
            )
        if changes & Change.LINK_REGAINED:
            log.warning("link_regained", link_lost_count=st.link_lost_count)
        if changes & (Change.REBOOT | Change.LINK_REGAINED):
            self._rerequest_streams()
        if changes & Change.MODE:
            log.info("autopilot_mode", mode=st.mode, custom_mode=st.custom_mode)
        if changes & Change.ARMED:
            log.info("autopilot_armed" if st.armed else "autopilot_disarmed")

    def _on_foreign(self, sysid: int) -> None:
        if sysid not in self.state.foreign_sysid_counts:
            log.info("foreign_system_ignored", sysid=sysid, target_system=self.cfg.target_system)
        self.state.count_foreign(sysid)

    def _on_transport_lost(self, reason: str) -> None:
        if self.state.mark_link_lost(reason):
            log.warning("link_lost", cause=reason, link_lost_count=self.state.link_lost_count)

    def _on_reopened(self) -> None:
        log.info("link_waiting_for_heartbeat", url=self.url.text)

    async def _housekeeping(self) -> None:
        """One periodic wake-up for the link's chores (it used to be one task each): the
        heartbeat-silence watch and expired STATUSTEXT chunks every heartbeat_timeout/4, and
        — once streams were requested — the stream-rate check (its re-requests run as a task
        of their own, so a slow COMMAND_ACK never delays the watch)."""
        timeout_s = self.limits.heartbeat_timeout_s
        period_s = min(timeout_s, self.cfg.stream_check_window_s) / 4
        rerequest: asyncio.Task[None] | None = None
        while True:
            await asyncio.sleep(period_s)
            st = self.state
            now = now_s()
            changes = self._expired_texts(now)  # a text whose end never came
            if changes:
                self._on_changes(changes)
            if st.check_link(now, timeout_s):
                log.warning(
                    "link_lost",
                    cause="heartbeat silence",
                    timeout_s=timeout_s,
                    link_lost_count=st.link_lost_count,
                )
            if self._monitoring and (rerequest is None or rerequest.done()):
                booting = st.mode == "INITIALISING" or st.system_status == MAV_STATE_BOOT
                origin_known = st.gps_origin is not None or st.pose is not None
                slow = self._streams.due(now, not st.link_lost, booting, origin_known)
                if slow:
                    rerequest = self._spawn(
                        self._streams.rerequest_and_restart(slow, booting), "stream_rerequest"
                    )

    def _rerequest_streams(self) -> None:
        if not self._streams.requested:
            return
        if self._rerequest is not None and not self._rerequest.done():
            return
        self._rerequest = self._spawn(self._request_again(), "stream_rerequest")

    async def _request_again(self) -> None:
        try:
            granted = await self._streams.request_all()
            log.info("streams_rerequested", rates_hz=granted)
        except CommandError as exc:
            log.warning("streams_rerequest_failed", error=str(exc))

    # -- heartbeats ---------------------------------------------------------------------------

    async def wait_heartbeat(self, timeout_s: float) -> None:
        """Return once the autopilot's HEARTBEAT arrives; LinkTimeout with hints otherwise."""
        st = self.state
        deadline = now_s() + timeout_s
        announce = self.url.kind == "udpout" and not self._heartbeat.running
        while st.last_heartbeat_s is None or st.link_lost:
            remaining = deadline - now_s()
            if remaining <= 0:
                raise LinkTimeout(
                    no_heartbeat_text(self.cfg, self.url, self._conn.stats, st, timeout_s)
                )
            if announce:  # a udpout peer learns our address from what we send
                self._announce()
            await self._waiters.wait(
                Change.HEARTBEAT, min(remaining, 1.0 / self.cfg.heartbeat_rate_hz)
            )
        log.info("autopilot_heartbeat", mode=st.mode, armed=st.armed, mav_type=st.mav_type)

    def _announce(self) -> None:
        """Something for a udpout peer to learn our address from: our HEARTBEAT, or for an
        observer (which never sends one) a request for the autopilot's HEARTBEAT."""
        if not self.observer:
            self._heartbeat.send_now()
            return
        self.request_heartbeat()

    def request_heartbeat(self) -> None:
        """Ask the autopilot for a HEARTBEAT now (MAV_CMD_REQUEST_MESSAGE, its ACK not
        awaited): a mode or arm just acknowledged shows in it at once, not at the next of its
        1 Hz HEARTBEATs."""
        self._conn.send(
            self._conn.mav.command_long_encode(
                self.cfg.target_system,
                self.cfg.target_component,
                MAV_CMD_REQUEST_MESSAGE,
                0,
                float(MAVLINK_MSG_ID_HEARTBEAT),
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
            )
        )

    def start_heartbeat(self) -> None:
        """Start our HEARTBEAT; counts as a feed(). Call feed() from the control loop."""
        if self.observer:
            raise NeverSent("an observer link never sends HEARTBEAT")
        self._heartbeat.start()

    def feed(self) -> None:
        self._heartbeat.feed()

    def stop_heartbeat(self) -> None:
        self._heartbeat.stop()

    # -- streams and pose ---------------------------------------------------------------------

    async def request_streams(self) -> dict[str, float]:
        """Negotiate every stream (see :mod:`helixd.link.streams`); name → granted Hz."""
        granted = await self._streams.request_all()
        self._monitoring = True  # the housekeeping tick checks the stream rates from now on
        return granted

    async def pace_pose(self, rate_hz: float | None) -> None:
        """The pose streams at ``rate_hz``, or back at the negotiated rate (None): see
        :meth:`helixd.link.streams.StreamManager.pace_pose`."""
        await self._streams.pace_pose(rate_hz)

    # -- raw messages and the link log --------------------------------------------------------

    def send_message(self, msg: MavMsg) -> bool:
        """Send one pymavlink message as it is (our system/component ids, the link's sequence,
        signed when the link is). Never blocks; False when the transport dropped it (full
        socket buffer, link down) — the caller decides whether that matters."""
        sent: bool = self._conn.send(msg)
        return sent

    def send_as_vehicle(self, msg: MavMsg) -> bool:
        """Send one message from our component of the autopilot's system
        (``link.vehicle_component``): the answer to a command addressed there."""
        sent: bool = self._conn.send_as_vehicle(msg)
        return sent

    @property
    def tlog(self) -> LinkTlog | None:
        """The link log being recorded, if any."""
        return self._conn.tlog

    def attach_tlog(self, tlog: LinkTlog | None) -> None:
        """Record every frame sent and read to ``tlog`` from now on (None stops recording);
        see :func:`helixd.link.wire.tlog.attach_tlog`."""
        self._conn.tlog = tlog
