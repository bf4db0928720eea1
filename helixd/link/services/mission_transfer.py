"""MAVLink mission protocol client, sans-IO: upload and download of mission items.

:class:`MissionUpload` and :class:`MissionDownload` are state machines. Feed them each received
message with ``on_message(msg, now_s)`` and the passing of time with ``on_time(now_s)``; both
return the messages to send. ``done`` says the transfer ended, ``error`` why it failed (None:
success), ``deadline_s`` when ``on_time`` must be called next. They do no I/O, read no clock and log
nothing. :func:`run_transfer` is the one thin async shell running either over a
:class:`MissionLink`.

Behaviour follows the clients ground stations use (QGroundControl's PlanManager, MAVSDK's
MavlinkMissionTransfer) against ArduPilot (``MissionItemProtocol.cpp``):

* Upload: MISSION_COUNT; the vehicle asks for each item with MISSION_REQUEST (ArduPilot) or
  MISSION_REQUEST_INT (the newer spec) — both are answered with MISSION_ITEM_INT. Duplicated or
  earlier requests are answered again (the vehicle re-asks after 1 s when an item was lost); a
  request past the end fails the transfer. MISSION_ACK ACCEPTED after every item was requested
  ends it; any other MISSION_ACK fails it with the result's name (e.g. MAV_MISSION_NO_SPACE).
  An ACK of INVALID_SEQUENCE is only a complaint about one item (ArduPilot goes on), so it
  does not end the upload.
* Download: MISSION_REQUEST_LIST → MISSION_COUNT, then MISSION_REQUEST_INT for each seq in
  order; an item with another seq is ignored; at the end MISSION_ACK ACCEPTED to the vehicle.
  MISSION_ITEM (float) answers are accepted too (lat/lon scaled to degE7).
* Without progress for ``item_timeout_s`` the last message is sent again, at most ``retries``
  times in a row (the count restarts at each progress), then the transfer fails with a
  timeout; a download that fails sends MISSION_ACK OPERATION_CANCELLED so the vehicle stops.

Only messages from the target system/component and of the transfer's mission type count and,
given ``own_ids`` (our sysid, compid), only those addressed to us (or broadcast): the vehicle's
answers to a ground station transferring at the same time are not ours.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

from helixd.link.services.inbox import drive

os.environ.setdefault("MAVLINK20", "1")

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.clock import now_s
from helixd.mav.constants import (
    MAV_MISSION_ACCEPTED,
    MAV_MISSION_INVALID_SEQUENCE,
    MAV_MISSION_OPERATION_CANCELLED,
    MAV_MISSION_TYPE_FENCE,
    MAV_MISSION_TYPE_MISSION,
    MAV_MISSION_TYPE_RALLY,
)
from helixd.mav.mission_item import (
    MissionItem,
    check_item,
    item_from_message,
    mission_result_name,
    wire_xy,
)

__all__ = [
    "MissionDownload",
    "MissionLink",
    "MissionTransferError",
    "MissionUpload",
    "Transfer",
    "run_transfer",
]

_mav = mavlink.MAVLink(None)


class MissionTransferError(Exception):
    """Why a transfer failed; ``result`` is the vehicle's MAV_MISSION_RESULT if it sent one."""

    def __init__(self, message: str, result: int | None = None) -> None:
        super().__init__(message)
        self.result = result
        self.vehicle_text: str | None = None  # what the vehicle said about it (STATUSTEXT)

    def __str__(self) -> str:
        base = super().__str__()
        return base if not self.vehicle_text else f"{base} (autopilot: {self.vehicle_text})"


@dataclass(eq=False, repr=False)
class Transfer:
    """Shared retry/timeout bookkeeping of an upload or a download: whose items of which
    ``mission_type``, how long to wait for each answer and how often to ask again."""

    mission_type: int
    target_system: int
    target_component: int
    item_timeout_s: float
    retries: int
    own_ids: tuple[int, int] | None = None

    def __post_init__(self) -> None:
        timeout_s = self.item_timeout_s
        if not (math.isfinite(timeout_s) and timeout_s > 0.0) or self.retries < 0:
            raise ValueError("item_timeout_s must be > 0 and retries >= 0")
        if self.mission_type not in (
            MAV_MISSION_TYPE_MISSION,
            MAV_MISSION_TYPE_FENCE,
            MAV_MISSION_TYPE_RALLY,
        ):
            raise ValueError(f"unknown mission_type {self.mission_type}")
        self.done = False
        self.error: MissionTransferError | None = None
        self.deadline_s = math.inf
        self.resends = 0  # total re-sends on timeout (for tests and logs)
        self._tries = 0
        self._last: list[Any] = []
        self._fresh()

    def _fresh(self) -> None:
        """A subclass's own checks and state, at the end of ``__post_init__``."""

    def _ours(self, msg: Any) -> bool:
        if self.done:
            return False
        if int(msg.get_srcSystem()) != self.target_system:
            return False
        if self.target_component and int(msg.get_srcComponent()) != self.target_component:
            return False
        if self.own_ids is not None:
            # the vehicle's answers to another GCS on the same link are not ours
            if int(getattr(msg, "target_system", 0)) not in (0, self.own_ids[0]):
                return False
            if int(getattr(msg, "target_component", 0)) not in (0, self.own_ids[1]):
                return False
        return int(getattr(msg, "mission_type", 0)) == self.mission_type

    def _send(self, msgs: list[Any], now_s: float, progress: bool = True) -> list[Any]:
        self._last = msgs
        if progress:
            self._tries = 0
        self.deadline_s = now_s + self.item_timeout_s
        return msgs

    def _fail(self, error: MissionTransferError) -> None:
        self.done = True
        self.error = error
        self.deadline_s = math.inf

    def _succeed(self) -> None:
        self.done = True
        self.deadline_s = math.inf

    def on_time(self, now_s: float) -> list[Any]:
        """Re-send the last message if nothing came for ``item_timeout_s``; give up after."""
        if self.done or now_s < self.deadline_s:
            return []
        if self._tries >= self.retries:
            self._fail(
                MissionTransferError(f"{self._stage()}: no answer after {self._tries} retries")
            )
            return self._on_give_up()
        self._tries += 1
        self.resends += 1
        return self._send(self._last, now_s, progress=False)

    def _stage(self) -> str:
        return "mission transfer"

    def _on_give_up(self) -> list[Any]:
        return []

    def _ack(self, result: int) -> Any:
        return _mav.mission_ack_encode(
            self.target_system, self.target_component, result, self.mission_type
        )


@dataclass(eq=False, repr=False)
class MissionUpload(Transfer):
    """Send ``items`` (their seq must be 0..n-1 in order) to the vehicle."""

    items: tuple[MissionItem, ...] = field(kw_only=True)  # a list is taken as a tuple

    def _fresh(self) -> None:
        for i, item in enumerate(self.items):
            check_item(item)
            if item.seq != i:
                raise ValueError(f"mission item {i} has seq {item.seq}: seq must be 0..n-1")
            if item.mission_type != self.mission_type:
                raise ValueError(f"mission item {i} is of mission_type {item.mission_type}")
        if len(self.items) > 65535:
            raise ValueError("more than 65535 mission items")
        self.items = tuple(self.items)
        self.requested: set[int] = set()

    def _stage(self) -> str:
        return f"upload ({len(self.requested)}/{len(self.items)} items requested)"

    def start(self, now_s: float) -> list[Any]:
        count = _mav.mission_count_encode(
            self.target_system, self.target_component, len(self.items), self.mission_type
        )
        return self._send([count], now_s)

    def _item_msg(self, seq: int) -> Any:
        it = self.items[seq]
        x, y = wire_xy(it)
        return _mav.mission_item_int_encode(
            self.target_system, self.target_component, it.seq, it.frame, it.command,
            it.current, it.autocontinue, it.param1, it.param2, it.param3, it.param4,
            x, y, it.z, it.mission_type,
        )  # fmt: skip

    def on_message(self, msg: Any, now_s: float) -> list[Any]:
        kind = msg.get_type()
        if kind not in ("MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"):
            return []
        if not self._ours(msg):
            return []
        if kind == "MISSION_ACK":
            result = int(msg.type)
            if result == MAV_MISSION_INVALID_SEQUENCE:
                return []  # a complaint about one item; the vehicle re-requests the right one
            if result != MAV_MISSION_ACCEPTED:
                name = mission_result_name(result)
                self._fail(MissionTransferError(f"upload refused: {name}", result))
            elif len(self.requested) < len(self.items):
                missing = len(self.items) - len(self.requested)
                self._fail(MissionTransferError(f"upload acked with {missing} items not sent"))
            else:
                self._succeed()
            return []
        seq = int(msg.seq)
        if not 0 <= seq < len(self.items):
            self._fail(MissionTransferError(f"vehicle asked for item {seq} of {len(self.items)}"))
            return []
        progress = seq not in self.requested
        self.requested.add(seq)
        return self._send([self._item_msg(seq)], now_s, progress)


class MissionDownload(Transfer):
    """Read the vehicle's items of ``mission_type``; ``items`` holds them when ``done``."""

    def _fresh(self) -> None:
        self.count: int | None = None  # the vehicle's MISSION_COUNT, once heard
        self.received: list[MissionItem] = []

    @property
    def items(self) -> tuple[MissionItem, ...]:
        return tuple(self.received)

    def _stage(self) -> str:
        if self.count is None:
            return "download (no MISSION_COUNT)"
        return f"download ({len(self.received)}/{self.count} items)"

    def _on_give_up(self) -> list[Any]:
        return [self._ack(MAV_MISSION_OPERATION_CANCELLED)]

    def start(self, now_s: float) -> list[Any]:
        req = _mav.mission_request_list_encode(
            self.target_system, self.target_component, self.mission_type
        )
        return self._send([req], now_s)

    def _request(self, seq: int) -> Any:
        return _mav.mission_request_int_encode(
            self.target_system, self.target_component, seq, self.mission_type
        )

    def on_message(self, msg: Any, now_s: float) -> list[Any]:
        kind = msg.get_type()
        if kind not in ("MISSION_COUNT", "MISSION_ITEM_INT", "MISSION_ITEM", "MISSION_ACK"):
            return []
        if not self._ours(msg):
            return []
        if kind == "MISSION_ACK":
            result = int(msg.type)
            if result != MAV_MISSION_ACCEPTED:
                name = mission_result_name(result)
                self._fail(MissionTransferError(f"download refused: {name}", result))
            return []
        if kind == "MISSION_COUNT":
            count = int(msg.count)
            if self.count is not None:
                return []  # a duplicate, or ArduPilot "educating" us after a bad request
            self.count = count
            if count == 0:
                self._succeed()
                return [self._ack(MAV_MISSION_ACCEPTED)]
            return self._send([self._request(0)], now_s)
        if self.count is None:
            return []
        item = item_from_message(msg)
        if item is None or item.seq != len(self.received):
            return []  # duplicate or out of order: the next timeout re-requests
        self.received.append(item)
        if len(self.received) == self.count:
            self._succeed()
            return [self._ack(MAV_MISSION_ACCEPTED)]
        return self._send([self._request(len(self.received))], now_s)


class MissionLink(Protocol):
    """What :func:`run_transfer` needs of a link: send, and receive with a timeout."""

    def send(self, msg: Any) -> None: ...

    async def recv(self, timeout_s: float) -> Any | None:
        """The next received message, or None if none came within ``timeout_s``."""
        ...


async def run_transfer(
    transfer: MissionUpload | MissionDownload,
    link: MissionLink,
    clock: Callable[[], float] = now_s,
) -> MissionUpload | MissionDownload:
    """Drive ``transfer`` over ``link`` until it ends; raises its error if it failed."""
    await drive(transfer, link.send, link.recv, transfer.on_message, clock)
    return transfer
