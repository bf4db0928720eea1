"""The mission plugin: the mission protocol over the daemon's link, attached to
:class:`helixd.link.connection.Autopilot` as ``ap.mission`` (``await ap.mission.download()``,
``await ap.mission.upload(mission, fence)``), over a
:class:`helixd.link.services.mission_transfer.MissionLink` adapter on the Autopilot's message
listener.

Received MISSION_* messages come through the Autopilot's message listener (every message of
the autopilot's system, already filtered by the codec) into a bounded queue that exists only
while the transfer runs; everything else is left to the other consumers.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import structlog

from helixd.config.link import LinkConfig
from helixd.link.services.inbox import Inbox, ListenerHost, Listening
from helixd.link.services.mission_transfer import (
    MissionDownload,
    MissionTransferError,
    MissionUpload,
    run_transfer,
)
from helixd.mav.constants import (
    MAV_MISSION_TYPE_FENCE,
    MAV_MISSION_TYPE_MISSION,
    MAV_SEVERITY_WARNING,
)
from helixd.mav.mission_item import MissionItem

__all__ = [
    "MISSION_MESSAGES",
    "AutopilotMissionLink",
    "MissionClient",
    "MissionHost",
]

log = structlog.get_logger(__name__)

MavMsg = Any
MISSION_MESSAGES = frozenset(
    {"MISSION_COUNT", "MISSION_ITEM", "MISSION_ITEM_INT", "MISSION_REQUEST",
     "MISSION_REQUEST_INT", "MISSION_ACK"}
)  # fmt: skip
QUEUE_MAX = 256  # a transfer has at most a few messages in flight; older ones are dropped
TYPE_NAMES = {MAV_MISSION_TYPE_MISSION: "mission", MAV_MISSION_TYPE_FENCE: "fence"}
TEXTS_KEPT = 16
TEXT_MAX_CHARS = 200


class MissionHost(ListenerHost, Protocol):
    """What the adapter needs of the Autopilot facade."""

    cfg: LinkConfig


class AutopilotMissionLink(Listening):
    """``send`` / ``async recv(timeout_s)`` over the Autopilot; use as a context manager so
    the listener is removed after the transfer."""

    def __init__(self, host: MissionHost, send: Callable[[MavMsg], bool]) -> None:
        super().__init__(host)
        self._send = send
        self._inbox: Inbox[MavMsg] = Inbox(QUEUE_MAX)
        self.texts: list[str] = []  # the vehicle's warnings (and worse) during the transfer
        self._text_seen = asyncio.Event()

    def _put(self, msg: MavMsg, rx_s: float) -> None:
        kind = msg.get_type()
        if kind == "STATUSTEXT":
            self._note_text(msg)
            return
        if kind not in MISSION_MESSAGES:
            return
        self._inbox.put(msg)

    def _note_text(self, msg: MavMsg) -> None:
        try:
            severity, text = int(msg.severity), str(msg.text).strip()
        except (AttributeError, TypeError, ValueError):
            return
        if severity <= MAV_SEVERITY_WARNING and text:
            self.texts.append(text[:TEXT_MAX_CHARS])
            del self.texts[:-TEXTS_KEPT]
            self._text_seen.set()

    async def refusal_text(self, since: int, grace_s: float) -> str | None:
        """The first warning the vehicle sent after ``len(texts) == since`` (ArduPilot sends it
        right after the refusing MISSION_ACK), waiting at most ``grace_s`` for it."""
        if len(self.texts) <= since and grace_s > 0:
            self._text_seen.clear()
            try:
                async with asyncio.timeout(grace_s):
                    while len(self.texts) <= since:
                        await self._text_seen.wait()
                        self._text_seen.clear()
            except TimeoutError:
                return None
        return self.texts[since] if len(self.texts) > since else None

    def send(self, msg: MavMsg) -> None:
        self._send(msg)

    async def recv(self, timeout_s: float) -> MavMsg | None:
        return await self._inbox.get(timeout_s)


@dataclass(frozen=True, slots=True)
class Downloaded:
    mission: tuple[MissionItem, ...]
    fence: tuple[MissionItem, ...]


async def transfer(
    link: AutopilotMissionLink, t: MissionUpload | MissionDownload, grace_s: float
) -> MissionUpload | MissionDownload:
    """:func:`run_transfer`; a refusal carries the vehicle's warning that explains it."""
    since = len(link.texts)
    try:
        return await run_transfer(t, link)
    except MissionTransferError as exc:
        kind = TYPE_NAMES.get(t.mission_type, "mission")
        exc.args = (f"{kind} {exc.args[0]}", *exc.args[1:])  # "fence upload refused: ..."
        if exc.result is not None:
            exc.vehicle_text = await link.refusal_text(since, grace_s)
        raise


def _ids(cfg: LinkConfig) -> dict[str, Any]:
    return {
        "target_system": cfg.target_system,
        "target_component": cfg.target_component,
        "item_timeout_s": cfg.mission_item_timeout_s,
        "retries": cfg.mission_retries,
        "own_ids": (cfg.source_system, cfg.source_component),
    }


class MissionClient:
    """The mission plugin (MAVSDK's ``Mission``): whole-mission download and upload, each in
    its own :class:`AutopilotMissionLink` on ``host`` sending with ``send``."""

    def __init__(self, host: MissionHost, send: Callable[[MavMsg], bool]) -> None:
        self._host = host
        self._send = send

    async def download(self, fence: bool = True) -> Downloaded:
        """The autopilot's mission (seq 0 = home) and, if ``fence``, its fence; raises
        :class:`helixd.link.services.mission_transfer.MissionTransferError`."""
        with AutopilotMissionLink(self._host, self._send) as link:
            m_items = await self._download(link, MAV_MISSION_TYPE_MISSION)
            f_items = await self._download(link, MAV_MISSION_TYPE_FENCE) if fence else ()
        return Downloaded(m_items, f_items)

    async def download_fence(self) -> tuple[MissionItem, ...]:
        """The autopilot's fence items only; raises
        :class:`helixd.link.services.mission_transfer.MissionTransferError`."""
        with AutopilotMissionLink(self._host, self._send) as link:
            return await self._download(link, MAV_MISSION_TYPE_FENCE)

    async def _download(
        self, link: AutopilotMissionLink, mission_type: int
    ) -> tuple[MissionItem, ...]:
        """The autopilot's items of ``mission_type`` over ``link``."""
        cfg = self._host.cfg
        got = await transfer(
            link, MissionDownload(mission_type, **_ids(cfg)), cfg.statustext_grace_s
        )
        kind = TYPE_NAMES.get(mission_type, "mission")
        log.info("mission_downloaded", mission_type=kind, items=len(got.items))
        return got.items

    async def upload(
        self, mission: tuple[MissionItem, ...], fence: tuple[MissionItem, ...] | None
    ) -> None:
        """Upload the mission, then (unless None) the fence — an empty fence clears it, as QGC
        does for a plan without one. Raises
        :class:`helixd.link.services.mission_transfer.MissionTransferError`."""
        ids = _ids(self._host.cfg)
        parts = [(MAV_MISSION_TYPE_MISSION, mission)]
        if fence is not None:
            parts.append((MAV_MISSION_TYPE_FENCE, fence))
        with AutopilotMissionLink(self._host, self._send) as link:
            grace_s = self._host.cfg.statustext_grace_s
            for kind, items in parts:
                await transfer(link, MissionUpload(kind, items=items, **ids), grace_s)
                log.info("mission_uploaded", mission_type=TYPE_NAMES[kind], items=len(items))
