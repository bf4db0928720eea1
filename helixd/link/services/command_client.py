"""COMMAND_LONG with acknowledgement matching, and parameter reads/writes.

MAVLink's COMMAND_ACK carries only the command id and the result, so acks are matched to
sends in order, per command id:

* one command per id is in flight at a time (different ids may overlap);
* every send of a command (first try and re-sends) is queued; an ack consumes the oldest
  queued send of its id. When a command is answered, its other sends stay queued as
  *expected duplicates* for ``2 × command_timeout_s``: the late ack of a re-sent try is then
  swallowed instead of satisfying the next command with the same id;
* after an answer, the next command with the same id waits until ``command_settle_s`` has
  passed since that answer: a duplicated ack (two routes to the autopilot, a repeating radio)
  arriving in that gap finds nothing outstanding and is dropped. The reader also drains the
  socket before any woken command runs, so duplicates already queued never reach it;
* MAV_RESULT_IN_PROGRESS extends the wait without a re-send;
* no answer after ``1 + retries`` tries raises :class:`CommandTimeout` naming the command
  (its tries are then forgotten: a peer that never answered owes no duplicates).

Limitation (MAVLink's, not ours): COMMAND_ACK carries no request id, so a duplicate delayed
by more than ``command_settle_s`` after the next same-id command was sent cannot be told
apart from that command's answer.
"""

from __future__ import annotations

import asyncio
import math
from collections import defaultdict, deque
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass, field
from typing import Any, TypeVar

import structlog
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.clock import now_s
from helixd.config.link import LinkConfig
from helixd.link.vehicle import VehicleState
from helixd.mav.constants import MAV_RESULT_ACCEPTED, MAV_RESULT_IN_PROGRESS
from helixd.mav.url import LinkError

log = structlog.get_logger(__name__)

MavMsg = Any
SendFn = Callable[[MavMsg], bool]
T = TypeVar("T")

ALL_RESULTS: frozenset[int] = frozenset(int(k) for k in mavlink.enums["MAV_RESULT"]) - {
    int(mavlink.MAV_RESULT_ENUM_END)
}
COMMAND_LONG_PARAMS = 7
DUPLICATE_LIFETIME_TIMEOUTS = 2.0  # answered command's other sends stay expected this long
MAV_PARAM_TYPE_REAL32 = int(mavlink.MAV_PARAM_TYPE_REAL32)


def command_name(command: int) -> str:
    entry = mavlink.enums["MAV_CMD"].get(command)
    return str(entry.name) if entry is not None else f"MAV_CMD_{command}"


def result_name(result: int) -> str:
    entry = mavlink.enums["MAV_RESULT"].get(result)
    return str(entry.name).removeprefix("MAV_RESULT_") if entry is not None else str(result)


class CommandError(LinkError):
    """A command or parameter exchange with the autopilot failed."""


class CommandRejected(CommandError):
    def __init__(
        self, command: str, result: int, statustext: str | None = None, detail: str = ""
    ) -> None:
        self.command_name = command
        self.result = result
        self.result_name = result_name(result)
        self.statustext = statustext
        text = f"{command} refused by the autopilot: {self.result_name}"
        if detail:
            text += f" ({detail})"
        if statustext:
            text += f"; it said: {statustext!r}"
        super().__init__(text)


class CommandTimeout(CommandError):
    def __init__(self, command: str, tries: int, timeout_s: float) -> None:
        self.command_name = command
        self.tries = tries
        self.timeout_s = timeout_s
        super().__init__(
            f"{command}: no answer from the autopilot after {tries} tries of {timeout_s:g} s "
            f"(link down, wrong target_system/target_component, or signing mismatch?)"
        )


@dataclass(eq=False)
class _PendingCommand:
    command: int
    future: asyncio.Future[int]
    last_progress_s: float | None = None


@dataclass(eq=False)
class _Send:
    sent_s: float
    owner: _PendingCommand | None  # None once the command is over (answered or given up)


@dataclass
class AckStats:
    matched: int = 0
    duplicates: int = 0
    unexpected: int = 0
    foreign: int = 0


@dataclass
class _Queues:
    sends: dict[int, deque[_Send]] = field(default_factory=lambda: defaultdict(deque))
    locks: dict[int, asyncio.Lock] = field(default_factory=lambda: defaultdict(asyncio.Lock))
    answered_s: dict[int, float] = field(default_factory=dict)  # last matched ack per id


class CommandClient:
    """Sends COMMAND_LONG / PARAM_* and matches the answers. Fed by the link's reader."""

    def __init__(self, mav: Callable[[], Any], send: SendFn, cfg: LinkConfig, state: VehicleState):
        self._mav = mav  # the codec may be replaced on reconnect: always ask for the current one
        self._send = send
        self._cfg = cfg
        self._state = state
        self._q = _Queues()
        self._param_waiters: dict[str, list[asyncio.Future[float]]] = defaultdict(list)
        self._param_locks: dict[str, asyncio.Lock] = defaultdict(asyncio.Lock)
        # told of every PARAM_VALUE of the autopilot (name, value): a cache of them
        self.param_seen: Callable[[str, float], None] | None = None
        self.stats = AckStats()

    # -- reader side --------------------------------------------------------------------------

    def on_message(self, msg: MavMsg, rx_s: float) -> None:
        mtype = msg.get_type()
        if mtype == "COMMAND_ACK":
            self._on_ack(msg, rx_s)
        elif mtype == "PARAM_VALUE":
            self._on_param_value(msg)

    def _ours(self, msg: MavMsg) -> bool:
        comp = self._cfg.target_component
        if comp and int(msg.get_srcComponent()) != comp:
            return False
        tsys = int(getattr(msg, "target_system", 0) or 0)
        tcomp = int(getattr(msg, "target_component", 0) or 0)
        return tsys in (0, self._cfg.source_system) and tcomp in (0, self._cfg.source_component)

    def _on_ack(self, msg: MavMsg, rx_s: float) -> None:
        if not self._ours(msg):
            self.stats.foreign += 1
            return
        command, result = int(msg.command), int(msg.result)
        queue = self._q.sends[command]
        self._prune(queue, rx_s)
        if not queue:
            self.stats.unexpected += 1
            log.debug("ack_unexpected", command=command_name(command), result=result_name(result))
            return
        owner = queue[0].owner
        if owner is None or owner.future.done():
            queue.popleft()
            self.stats.duplicates += 1
            log.info(
                "ack_duplicate_discarded", command=command_name(command), result=result_name(result)
            )
            return
        if result == MAV_RESULT_IN_PROGRESS:
            owner.last_progress_s = rx_s
            return
        queue.popleft()
        self.stats.matched += 1
        self._q.answered_s[command] = rx_s
        owner.future.set_result(result)
        for send in queue:
            if send.owner is owner:
                send.owner = None  # its ack, if it ever comes, is a duplicate

    def _prune(self, queue: deque[_Send], now_s: float) -> None:
        lifetime_s = DUPLICATE_LIFETIME_TIMEOUTS * self._cfg.command_timeout_s
        keep = [s for s in queue if s.owner is not None or now_s - s.sent_s <= lifetime_s]
        if len(keep) != len(queue):
            queue.clear()
            queue.extend(keep)

    def _on_param_value(self, msg: MavMsg) -> None:
        comp = self._cfg.target_component
        if comp and int(msg.get_srcComponent()) != comp:
            return
        name = _param_text(msg.param_id)
        if self.param_seen is not None:
            self.param_seen(name, float(msg.param_value))
        for fut in self._param_waiters.get(name, []):
            if not fut.done():
                fut.set_result(float(msg.param_value))

    # -- commands -----------------------------------------------------------------------------

    async def exchange(
        self,
        command: int,
        params: Sequence[float],
        timeout_s: float | None = None,
        retries: int | None = None,
        ok_results: Collection[int] = (MAV_RESULT_ACCEPTED,),
    ) -> int:
        """Send, re-send on silence, return the MAV_RESULT if in ``ok_results``.

        Raises CommandRejected (any other result) or CommandTimeout (no answer at all).
        """
        if len(params) > COMMAND_LONG_PARAMS:
            raise ValueError(f"COMMAND_LONG takes at most 7 params, got {len(params)}")
        p = [float(x) for x in params] + [0.0] * (COMMAND_LONG_PARAMS - len(params))
        timeout = self._cfg.command_timeout_s if timeout_s is None else timeout_s
        tries = 1 + (self._cfg.command_retries if retries is None else retries)
        name = command_name(command)
        loop = asyncio.get_running_loop()
        async with self._q.locks[command]:
            settle_s = self._q.answered_s.get(command, -math.inf) + self._cfg.command_settle_s
            if settle_s > now_s():
                await asyncio.sleep(settle_s - now_s())
            pending = _PendingCommand(command, loop.create_future())
            queue = self._q.sends[command]
            started_s = now_s()
            result: int | None = None
            try:
                result = await self._attempts(pending, queue, p, timeout, tries)
            finally:
                if result is None:
                    # never answered: no duplicates to expect, forget every try
                    kept = [s for s in queue if s.owner is not pending]
                    queue.clear()
                    queue.extend(kept)
                else:
                    for send in queue:
                        if send.owner is pending:
                            send.owner = None
            if result is None:
                # a link lost (said once, link_lost) or silent since the command was sent:
                # the link is the news, not each command it could not carry
                st = self._state
                silent = st.last_rx_s is None or st.last_rx_s < started_s
                emit = log.debug if st.link_lost or silent else log.warning
                emit("command_timeout", command=name, tries=tries, timeout_s=timeout)
                raise CommandTimeout(name, tries, timeout)
        if result in ok_results:
            log.debug("command_ok", command=name, result=result_name(result))
            return result
        text = self._state.latest_statustext(since_s=started_s)
        log.warning("command_rejected", command=name, result=result_name(result), statustext=text)
        raise CommandRejected(name, result, text)

    async def _attempts(
        self,
        pending: _PendingCommand,
        queue: deque[_Send],
        params: list[float],
        timeout_s: float,
        tries: int,
    ) -> int | None:
        cfg = self._cfg
        for attempt in range(tries):
            now = now_s()
            msg = self._mav().command_long_encode(
                cfg.target_system, cfg.target_component, pending.command, attempt, *params
            )
            queue.append(_Send(now, pending))
            self._send(msg)
            deadline = now + timeout_s
            while True:
                remaining = deadline - now_s()
                if remaining > 0 and await answered(pending.future, remaining):
                    return pending.future.result()
                if pending.last_progress_s is not None:
                    progress_deadline = pending.last_progress_s + timeout_s
                    if progress_deadline > now_s():
                        deadline = progress_deadline
                        continue
                break
            if attempt + 1 < tries:
                log.info(
                    "command_resend",
                    command=command_name(pending.command),
                    attempt=attempt + 2,
                    of=tries,
                )
        return None

    # -- parameters ---------------------------------------------------------------------------

    async def get_param(
        self, name: str, timeout_s: float | None = None, retries: int | None = None
    ) -> float | None:
        """The parameter's value, or None when the autopilot does not answer (no such param)."""
        cfg = self._cfg

        def request() -> MavMsg:
            return self._mav().param_request_read_encode(
                cfg.target_system, cfg.target_component, name.encode("ascii"), -1
            )

        return await self._param_exchange(name, request, timeout_s, retries)

    async def set_param(
        self, name: str, value: float, timeout_s: float | None = None, retries: int | None = None
    ) -> float:
        """Write a parameter; return the value the autopilot reports back."""
        cfg = self._cfg

        def request() -> MavMsg:
            return self._mav().param_set_encode(
                cfg.target_system,
                cfg.target_component,
                name.encode("ascii"),
                float(value),
                MAV_PARAM_TYPE_REAL32,
            )

        got = await self._param_exchange(name, request, timeout_s, retries)
        if got is None:
            tries = 1 + (cfg.command_retries if retries is None else retries)
            raise CommandTimeout(
                f"PARAM_SET {name}",
                tries,
                cfg.command_timeout_s if timeout_s is None else timeout_s,
            )
        log.info("param_set", name=name, requested=value, value=got)
        return got

    async def _param_exchange(
        self,
        name: str,
        request: Callable[[], MavMsg],
        timeout_s: float | None,
        retries: int | None,
    ) -> float | None:
        if not name or len(name) > 16 or not name.isascii():
            raise ValueError(f"parameter names are 1..16 ASCII characters, got {name!r}")
        timeout = self._cfg.command_timeout_s if timeout_s is None else timeout_s
        tries = 1 + (self._cfg.command_retries if retries is None else retries)
        async with self._param_locks[name]:
            fut: asyncio.Future[float] = asyncio.get_running_loop().create_future()
            waiters = self._param_waiters[name]
            waiters.append(fut)
            try:
                for _ in range(tries):
                    self._send(request())
                    if await answered(fut, timeout):
                        value = fut.result()
                        if math.isfinite(value):
                            return value
                        # Checked once, at the edge: a NaN/inf parameter reads as unreadable
                        # (preflight then refuses or warns instead of judging a NaN).
                        log.warning("param_value_not_finite", name=name, value=str(value))
                        return None
                return None
            finally:
                waiters.remove(fut)
                if not waiters:
                    self._param_waiters.pop(name, None)


async def answered(future: asyncio.Future[T], timeout_s: float) -> bool:
    """Wait up to ``timeout_s`` for ``future`` (never cancelling it); True when it is done.

    Not ``asyncio.wait_for(shield(future))``: on Python 3.11 that swallows a cancellation of
    the waiting task when the answer arrives in the same loop iteration (measured on SITL: an
    ACK and the HEARTBEAT that triggers a stop read in one TCP segment left the servo sender
    running and its stop() waiting 0.5 s). ``asyncio.wait`` lets the CancelledError through.
    """
    done, _ = await asyncio.wait({future}, timeout=timeout_s)
    return bool(done)


def _param_text(value: object) -> str:
    if isinstance(value, bytes | bytearray):
        value = value.decode("ascii", errors="replace")
    return str(value).rstrip("\x00")
