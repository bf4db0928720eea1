"""The FTP plugin: MAVLink FTP over the daemon's link, attached to
:class:`helixd.link.connection.Autopilot` as ``ap.ftp`` (``await ap.ftp.run(exchange)``), over
an :class:`helixd.link.services.ftp_transfer.FtpLink` adapter on the Autopilot, so
:func:`helixd.link.services.ftp_transfer.run_ftp` works over a real autopilot.

Received FILE_TRANSFER_PROTOCOL messages come through the Autopilot's message listener (every
message of the autopilot's system, already filtered by the codec); this adapter keeps those
from the autopilot's component addressed to us (``target_system`` = our system id,
``target_component`` ours or 0: ArduPilot's ``GCS_FTP::send_reply`` answers the request's
sender) in a bounded queue that exists only while the exchange runs. Requests go out addressed
to ``link.target_system`` / ``link.target_component`` with target_network 0.
"""

from __future__ import annotations

from typing import Any, Protocol, TypeVar

from helixd.config.link import LinkConfig
from helixd.link.services.ftp_transfer import FtpExchange, run_ftp
from helixd.link.services.inbox import Inbox, ListenerHost, Listening
from helixd.mav.ftp_wire import FtpPayload, FtpPayloadError, from_message, to_message

__all__ = ["AutopilotFtpLink", "FtpClient", "FtpHost"]

MavMsg = Any
QUEUE_MAX = 64  # one request is outstanding; a burst or duplicates are all that can pile up
E = TypeVar("E", bound=FtpExchange)


class FtpHost(ListenerHost, Protocol):
    """What the adapter needs of the Autopilot facade."""

    cfg: LinkConfig

    def send_message(self, msg: MavMsg) -> bool: ...


class AutopilotFtpLink(Listening):
    """``send(payload)`` / ``async recv(timeout_s)`` over the Autopilot; use as a context
    manager so the listener is removed after the exchange."""

    _host: FtpHost

    def __init__(self, host: FtpHost) -> None:
        super().__init__(host)
        cfg = host.cfg
        self._ours = (cfg.source_system, cfg.source_component)
        self._theirs = (cfg.target_system, cfg.target_component)
        self._inbox: Inbox[bytes] = Inbox(QUEUE_MAX)
        self.ignored = 0  # FILE_TRANSFER_PROTOCOL not for us (or unreadable)
        self.send_failed = 0  # requests the transport dropped (the exchange sends again)

    def _put(self, msg: MavMsg, rx_s: float) -> None:
        if msg.get_type() != "FILE_TRANSFER_PROTOCOL":
            return
        target_comp = self._theirs[1]
        if (
            (target_comp != 0 and int(msg.get_srcComponent()) != target_comp)
            or int(msg.target_system) != self._ours[0]
            or int(msg.target_component) not in (0, self._ours[1])
        ):
            self.ignored += 1
            return
        try:
            payload = from_message(msg)
        except FtpPayloadError:
            self.ignored += 1
            return
        self._inbox.put(payload)

    def send(self, payload: bytes) -> None:
        msg = to_message(FtpPayload.unpack(payload), *self._theirs)
        if not self._host.send_message(msg):
            self.send_failed += 1

    async def recv(self, timeout_s: float) -> bytes | None:
        return await self._inbox.get(timeout_s)


class FtpClient:
    """The FTP plugin (MAVSDK's ``Ftp``): runs one exchange at a time over ``host``."""

    def __init__(self, host: FtpHost) -> None:
        self._host = host

    async def run(self, exchange: E) -> E:
        """:func:`run_ftp` over the autopilot's link; raises the exchange's
        :class:`helixd.link.services.ftp_transfer.FtpTransferError` if it failed."""
        with AutopilotFtpLink(self._host) as link:
            return await run_ftp(exchange, link)
