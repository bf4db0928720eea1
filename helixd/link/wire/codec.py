"""The codec: MAVLink 2 framing, decode, system filtering, encode and signing on a transport
(:class:`MavlinkConnection`), and its fast paths.

Fast paths. :func:`helixd.link.wire.framing.scan_frames` has already checked the frame's CRC (with
the message's CRC_EXTRA) before anything here runs; pymavlink's ``decode`` would parse the
header and compute the CRC a second time and then build the message the same way this does.
For an *unsigned* frame of a message without arrays or strings (every stream the daemon flies
on: ATTITUDE, LOCAL_POSITION_NED, HEARTBEAT, SYS_STATUS, EKF_STATUS_REPORT, RC_CHANNELS,
SERVO_OUTPUT_RAW, COMMAND_ACK, ...), :class:`FrameDecoder` unpacks the payload into the very
pymavlink message class pymavlink would return, with the same fields and header. Anything
else (signed frames, arrays, strings, MAVLink 1) goes to pymavlink's own ``decode``; the
tests check both give the same message for arbitrary payloads.

:func:`pack_rc_channels_override` writes the same bytes as pymavlink's
``rc_channels_override_encode(...).pack(mav)`` for an unsigned link (MAVLink 2 trailing-zero
truncation included); a signing link uses pymavlink.

Reconnect: a serial device that vanishes (read error / EOF) or a TCP peer that closes is
reopened every ``reconnect_interval_s`` (:meth:`MavlinkConnection._reopen`) with a fresh codec.
"""

from __future__ import annotations

import asyncio
import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import structlog
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.clock import now_s
from helixd.config.link import LinkConfig
from helixd.link.wire.framing import FrameKind, scan_frames, whole_frame_msgid, x25_crc
from helixd.link.wire.ownid import OwnIdSenders
from helixd.link.wire.signing import enable_signing
from helixd.link.wire.tlog import LinkTlog
from helixd.link.wire.transport import Address, OnLost, make_transport
from helixd.mav.url import LinkError, LinkUrl

log = structlog.get_logger(__name__)

MavMsg = Any

MARKER_V2 = 0xFD
HEADER_V2_BYTES = 10
CRC_EXTRA: dict[int, int] = {
    int(msgid): int(cls.crc_extra) for msgid, cls in mavlink.mavlink_map.items()
}

_HEADER_V2 = struct.Struct("<BBBBBBBHB")
_CRC = struct.Struct("<H")


class _Plain:
    """How to build one message type from its payload (no arrays, no strings)."""

    __slots__ = ("cls", "order", "size", "unpack")

    def __init__(self, cls: Any) -> None:
        self.cls = cls
        self.unpack = cls.unpacker.unpack
        self.size = int(cls.unpacker.size)
        self.order = tuple(int(i) for i in cls.orders)


def _plain_entry(cls: Any) -> _Plain | None:
    lengths = list(cls.lengths)
    fmt = str(cls.unpacker.format)
    if sum(lengths) != len(lengths) or "s" in fmt or "c" in fmt:
        return None  # arrays or strings: pymavlink's decode handles them
    return _Plain(cls)


_PLAIN: dict[int, _Plain | None] = {
    int(msgid): _plain_entry(cls) for msgid, cls in mavlink.mavlink_map.items()
}


class FrameDecoder:
    """Decode one framed, CRC-checked frame: fast for plain unsigned MAVLink 2 messages,
    pymavlink's ``mav.decode`` for everything else (and always when signing is on)."""

    def __init__(self, mav: Any, signing: bool) -> None:
        self._mav = mav
        self._fast = not signing

    def decode(self, data: bytes) -> MavMsg:
        """The message; raises what ``mav.decode`` raises for frames it rejects."""
        if self._fast and data[0] == MARKER_V2 and data[2] == 0:
            msgid = data[7] | (data[8] << 8) | (data[9] << 16)
            entry = _PLAIN.get(msgid)
            plen = data[1]
            if entry is not None and len(data) == HEADER_V2_BYTES + plen + 2:
                return _decode_plain(entry, data, msgid, plen)
        return self._mav.decode(bytearray(data))


def _decode_plain(entry: _Plain, data: bytes, msgid: int, plen: int) -> MavMsg:
    payload = data[HEADER_V2_BYTES : HEADER_V2_BYTES + plen]
    size = entry.size
    if plen < size:
        payload += bytes(size - plen)  # MAVLink 2 trailing-zero truncation
    t = entry.unpack(payload[:size])
    m = entry.cls(*[t[i] for i in entry.order])
    msgbuf = bytearray(data)
    m._signed = False
    m._msgbuf = msgbuf
    m._payload = msgbuf[6:-2]  # as pymavlink (it slices from 6 for both versions)
    m._crc = data[-2] | (data[-1] << 8)
    m._header = mavlink.MAVLink_header(msgid, 0, data[3], plen, data[4], data[5], data[6])
    return m


_RC_OVERRIDE_ID = int(mavlink.MAVLINK_MSG_ID_RC_CHANNELS_OVERRIDE)
# what another system (a ground station) may address to helixd itself: commands
ADDRESSED_MESSAGE_IDS = frozenset(
    {int(mavlink.MAVLINK_MSG_ID_COMMAND_LONG), int(mavlink.MAVLINK_MSG_ID_COMMAND_INT)}
)
_RC_OVERRIDE_EXTRA = bytes((CRC_EXTRA[_RC_OVERRIDE_ID],))
_RC_OVERRIDE_PAYLOAD = struct.Struct("<8HBB10H")  # wire order: chan1..8, target, chan9..18


def pack_rc_channels_override(
    seq: int,
    src_system: int,
    src_component: int,
    target_system: int,
    target_component: int,
    channels_us: Sequence[int],
) -> bytes:
    """An unsigned MAVLink 2 RC_CHANNELS_OVERRIDE frame with 18 channel values (checked by the
    caller: 0..65535), byte for byte what pymavlink packs."""
    payload = _RC_OVERRIDE_PAYLOAD.pack(
        *channels_us[:8], target_system, target_component, *channels_us[8:18]
    )
    plen = len(payload)
    while plen > 1 and payload[plen - 1] == 0:
        plen -= 1
    body = (
        _HEADER_V2.pack(
            MARKER_V2,
            plen,
            0,
            0,
            seq,
            src_system,
            src_component,
            _RC_OVERRIDE_ID & 0xFFFF,
            _RC_OVERRIDE_ID >> 16,
        )
        + payload[:plen]
    )
    crc = x25_crc(_RC_OVERRIDE_EXTRA, x25_crc(body[1:]))
    return body + _CRC.pack(crc)


# ---------------------------------------------------------------------------------------------
# The connection: framing, decode, filtering by system, encode, reopen

REOPEN_LOG_EVERY = 10  # log every Nth failed reopen attempt (the first is always logged)


@dataclass
class LinkStats:
    rx_messages: int = 0
    bad_data: int = 0  # runs of bytes that were no valid frame (garbage, bad CRC, truncated)
    bad_bytes: int = 0
    unknown_messages: int = 0  # well-framed messages with an id our dialect does not know
    signature_rejects: int = 0
    tx_messages: int = 0
    tx_dropped: int = 0
    reopen_count: int = 0
    rx_addressed: int = 0  # commands from another system addressed to us (a GCS's)


class NeverSent(Exception):
    """A message this link must never send (an observer's HEARTBEAT, RC override or
    MANUAL_CONTROL): a bug in the caller, refused before it reaches the wire."""


@dataclass(frozen=True, slots=True)
class LinkEvents:
    """What the codec tells its owner (the Autopilot), each called in the event loop's thread."""

    message: Callable[[MavMsg, float], None]  # a message of the autopilot's system, rx time
    foreign: Callable[[int], None]  # a message from another system id (its id)
    lost: OnLost  # the transport failed (why); the codec reopens it
    reopened: Callable[[], None]  # the transport is open again
    # a command from another system addressed to us (helixd's component); None: dropped
    addressed: Callable[[MavMsg, float], None] | None = None


class MavlinkConnection:
    """MAVLink 2 codec on a transport: parse, drop other systems, dispatch, reopen.

    ``never_send``: message ids refused with :class:`NeverSent` instead of being sent (an
    observer link never sends what the autopilot counts as GCS contact).
    """

    def __init__(
        self,
        cfg: LinkConfig,
        url: LinkUrl,
        signing_key: bytes | None,
        events: LinkEvents,
        never_send: frozenset[int] = frozenset(),
    ) -> None:
        self.cfg = cfg
        self.events = events
        self.never_send = never_send
        self.url = url
        self._key = signing_key
        self.stats = LinkStats()
        self.own_id_senders = OwnIdSenders()
        self.first_tx_s: float | None = None  # monotonic time of our first message sent
        self.mav = self._new_codec(cfg.source_system)
        # link.vehicle_component: our component of the autopilot's system (see send_as_vehicle)
        self.vehicle_mav = self._new_codec(cfg.target_system)
        self._decoder = FrameDecoder(self.mav, signing=signing_key is not None)
        self._rxbuf = bytearray()  # stream transports: the incomplete frame at the end
        self.transport = make_transport(url, cfg, self._on_data, self._transport_lost)
        self.closed = False
        self._reopen_task: asyncio.Task[None] | None = None
        self.tlog: LinkTlog | None = None  # every frame sent/read (wire.tlog.attach_tlog)

    def _new_codec(self, system: int) -> Any:
        mav = mavlink.MAVLink(None, srcSystem=system, srcComponent=self.cfg.source_component)
        mav.robust_parsing = True
        if self._key is not None:
            enable_signing(mav, self._key)
        return mav

    async def open(self) -> None:
        await self.transport.open()
        log.info(
            "link_open",
            url=self.url.text,
            kind=self.url.kind,
            local=self.transport.local_address,
            signed=self._key is not None,
        )

    def send(self, msg: MavMsg) -> bool:
        return self._send_from(self.mav, msg)

    def send_as_vehicle(self, msg: MavMsg) -> bool:
        """Send ``msg`` from our component of the autopilot's system (``link.vehicle_component``:
        its HEARTBEAT, the answers to commands addressed there); its own sequence, signed when
        the link is. False when the transport dropped it or the identity is off."""
        if not self.cfg.vehicle_component:
            return False
        return self._send_from(self.vehicle_mav, msg)

    def _send_from(self, mav: Any, msg: MavMsg) -> bool:
        """Pack ``msg`` with the identity and sequence of ``mav`` and send it."""
        if self.never_send and int(msg.get_msgId()) in self.never_send:
            raise NeverSent(f"this link never sends {msg.get_type()}")
        buf = msg.pack(mav)
        mav.seq = (mav.seq + 1) % 256
        return self._write(bytes(buf))

    def send_rc_override(
        self, target_system: int, target_component: int, channels_us: Sequence[int]
    ) -> bool:
        """RC_CHANNELS_OVERRIDE (18 values, already checked), without a message object on an
        unsigned link (see :mod:`helixd.link.wire.codec`)."""
        if _RC_OVERRIDE_ID in self.never_send:
            raise NeverSent("this link never sends RC_CHANNELS_OVERRIDE")
        mav = self.mav
        if self._key is not None:
            return self.send(
                mav.rc_channels_override_encode(target_system, target_component, *channels_us)
            )
        buf = pack_rc_channels_override(
            mav.seq,
            self.cfg.source_system,
            self.cfg.source_component,
            target_system,
            target_component,
            channels_us,
        )
        mav.seq = (mav.seq + 1) % 256
        return self._write(buf)

    def _write(self, buf: bytes) -> bool:
        ok = self.transport.write(buf)
        if ok:
            if self.tlog is not None:
                self.tlog.record(buf)
            if self.first_tx_s is None:
                self.first_tx_s = now_s()
            self.stats.tx_messages += 1
        else:
            self.stats.tx_dropped += 1
        return ok

    def _on_data(self, data: bytes, addr: Address | None, rx_s: float) -> None:
        """Parse what one read returned (see :mod:`helixd.link.wire.framing`); never raises.

        A UDP datagram (``addr`` set) is parsed on its own: no parser state is carried into
        the next datagram. A stream keeps only an incomplete trailing frame for the next read.
        The common datagram — one whole known frame — is handled without a scan.
        """
        if addr is not None:
            msgid = whole_frame_msgid(data, CRC_EXTRA)
            if msgid is not None:
                if self._on_frame(FrameKind.KNOWN, msgid, data[5], data, rx_s):
                    self.transport.note_peer(addr)
                return
            scan = scan_frames(data, final=True, crc_extra=CRC_EXTRA)
        else:
            self._rxbuf += data
            scan = scan_frames(self._rxbuf, final=False, crc_extra=CRC_EXTRA)
            del self._rxbuf[: scan.consumed]
        stats = self.stats
        stats.bad_data += scan.bad_runs
        stats.bad_bytes += scan.bad_bytes
        from_target = False
        for frame in scan.frames:
            if self._on_frame(frame.kind, frame.msgid, frame.src_system, frame.data, rx_s):
                from_target = True
        if from_target and addr is not None:
            self.transport.note_peer(addr)

    def _on_frame(
        self, kind: FrameKind, msgid: int, src_system: int, data: bytes, rx_s: float
    ) -> bool:
        """Log, decode, filter by system and dispatch one frame; True if it came from the
        target system."""
        stats = self.stats
        if self.tlog is not None:
            self.tlog.record(data)
        if kind is FrameKind.UNKNOWN_ID:
            stats.unknown_messages += 1
            return False
        try:
            msg = self._decoder.decode(data)
        except mavlink.MAVError as exc:
            reason = str(getattr(exc, "message", exc))
            stats.bad_data += 1
            if "signature" in reason.lower():
                stats.signature_rejects += 1
            return False
        except Exception as exc:  # a decoder bug must not take the link down
            stats.bad_data += 1
            log.warning("mavlink_decode_failed", msgid=msgid, error=repr(exc))
            return False
        if src_system != self.cfg.target_system:  # the header byte the message carries too
            if src_system == self.cfg.source_system:
                self._note_own_id(msg)
            elif self._addressed_to_us(msgid, msg):
                self._dispatch_addressed(msg, rx_s)
            else:
                self.events.foreign(src_system)
            return False
        stats.rx_messages += 1
        try:
            self.events.message(msg, rx_s)
        except Exception:
            log.exception("message_handler_failed", type=msg.get_type())
        return True

    def _addressed_to_us(self, msgid: int, msg: MavMsg) -> bool:
        """A command from another system (a ground station, routed by the autopilot) whose
        target is our system and component (or every component), or our component of the
        autopilot's system (``link.vehicle_component``; not every component of it: those are
        the autopilot's commands)."""
        if self.events.addressed is None or msgid not in ADDRESSED_MESSAGE_IDS:
            return False
        system, component = int(msg.target_system), int(msg.target_component)
        if system == self.cfg.source_system:
            return component in (0, self.cfg.source_component)
        return (
            self.cfg.vehicle_component
            and system == self.cfg.target_system
            and component == self.cfg.source_component
        )

    def _dispatch_addressed(self, msg: MavMsg, rx_s: float) -> None:
        addressed = self.events.addressed
        assert addressed is not None
        self.stats.rx_addressed += 1
        try:
            addressed(msg, rx_s)
        except Exception:
            log.exception("message_handler_failed", type=msg.get_type())

    def _note_own_id(self, msg: MavMsg) -> None:
        """A message from *our* system id: somebody else uses it (see helixd.link.wire.ownid)."""
        mtype = str(msg.get_type())
        mav_type = int(msg.type) if mtype == "HEARTBEAT" else None
        compid = int(msg.get_srcComponent())
        if self.own_id_senders.note(compid, mtype, mav_type):
            log.warning(
                "own_sysid_in_use",
                sysid=self.cfg.source_system,
                compid=compid,
                type=mtype,
                mav_type=mav_type,
            )

    def _transport_lost(self, reason: str) -> None:
        if self.closed:
            return
        log.warning("link_transport_lost", url=self.url.text, reason=reason)
        self.events.lost(reason)
        if self._reopen_task is None or self._reopen_task.done():
            self._reopen_task = asyncio.get_running_loop().create_task(self._reopen())

    async def _reopen(self) -> None:
        attempts = 0
        while not self.closed:
            await asyncio.sleep(self.cfg.reconnect_interval_s)
            attempts += 1
            try:
                await self.transport.open()
            except LinkError as exc:
                if attempts == 1 or attempts % REOPEN_LOG_EVERY == 0:
                    log.info("link_reopen_failed", attempt=attempts, error=str(exc))
                continue
            self.mav = self._new_codec(self.cfg.source_system)
            self.vehicle_mav = self._new_codec(self.cfg.target_system)
            self._decoder = FrameDecoder(self.mav, signing=self._key is not None)
            self._rxbuf.clear()  # drop half a frame from the old stream
            self.stats.reopen_count += 1
            log.info("link_reopened", url=self.url.text, attempts=attempts)
            self.events.reopened()
            return

    async def close(self) -> None:
        self.closed = True
        task = self._reopen_task
        if task is not None and not task.done():
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)
        self.transport.close()
        if self.tlog is not None:
            self.tlog.close()
