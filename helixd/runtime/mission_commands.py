"""The mission's payload commands, sent to the autopilot at their place in the flight.

The control loop only queues them (:meth:`MissionCommands.submit`: no await on the latency
path); one task sends them in mission order, one at a time, as COMMAND_LONG through the
action plugin (its retries and acknowledgement check), and records each outcome in the run's
events (``mission_command``: item, command, parameters, result). A refusal is logged as a
warning and the mission goes on, as ArduPilot's AUTO goes on when a do command fails
(``AP_Mission::start_command`` returns false and the next item runs); ``helixd check`` has
already refused what would fight helixd (a servo output that drives a scroll).
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import structlog

from helixd.base.clock import now_s
from helixd.base.plan import MissionAction
from helixd.base.tasks import stop_task
from helixd.link.services.command_client import CommandError, CommandRejected, result_name
from helixd.mission.commands import command_name

log = structlog.get_logger(__name__)


class MissionCommandSender(Protocol):
    async def command_long(
        self,
        command: int,
        params: tuple[float, ...],
        timeout_s: float | None = None,
        retries: int | None = None,
    ) -> int: ...


@dataclass(frozen=True, slots=True)
class CommandOutcome:
    action: MissionAction
    accepted: bool
    result: str  # "MAV_RESULT_ACCEPTED", the refusal, or "no answer …"
    queued_s: float  # monotonic time it was queued
    answered_s: float  # … and answered (or given up)


class MissionCommands:
    """One flight's payload commands: queued by the loop, sent in order by one task."""

    def __init__(
        self,
        sender: MissionCommandSender,
        on_outcome: Callable[[CommandOutcome], None] | None = None,
    ) -> None:
        self._sender = sender
        self._on_outcome = on_outcome
        self._queue: asyncio.Queue[tuple[MissionAction, float]] = asyncio.Queue()
        self._task: asyncio.Task[None] | None = None
        self.outcomes: list[CommandOutcome] = []

    def start(self) -> None:
        if self._task is None:
            self._task = asyncio.create_task(self._run(), name="mission-commands")

    def submit(self, action: MissionAction) -> None:
        """Queue ``action`` (never blocks; the task sends it after those before it)."""
        self._queue.put_nowait((action, now_s()))

    @property
    def pending(self) -> int:
        return self._queue.qsize()

    async def close(self, timeout_s: float) -> None:
        """Let the queued commands go out (at most ``timeout_s``), then stop the task."""
        if self._task is None:
            return
        try:
            await asyncio.wait_for(self._queue.join(), timeout=timeout_s)
        except TimeoutError:
            log.warning("mission_commands_unsent", pending=self._queue.qsize())
        await stop_task(self._task)
        self._task = None

    async def _run(self) -> None:
        while True:
            action, queued_s = await self._queue.get()
            try:
                await self._send(action, queued_s)
            finally:
                self._queue.task_done()

    async def _send(self, action: MissionAction, queued_s: float) -> None:
        name = command_name(action.command)
        try:
            result = await self._sender.command_long(action.command, action.params)
            accepted, text = True, result_name(result)
        except CommandRejected as exc:
            accepted, text = False, str(exc)
        except CommandError as exc:
            accepted, text = False, str(exc)
        outcome = CommandOutcome(action, accepted, text, queued_s, now_s())
        self.outcomes.append(outcome)
        fields = {
            "item": action.item,
            "command": name,
            "params": [round(p, 7) for p in action.params],
            "result": text,
            "accepted": accepted,
            "sent_after_s": round(outcome.answered_s - queued_s, 3),
        }
        if accepted:
            log.info("mission_command", **fields)
        else:
            log.warning("mission_command", **fields)
        if self._on_outcome is not None:
            self._on_outcome(outcome)


__all__ = ["CommandOutcome", "MissionCommandSender", "MissionCommands"]
