"""A MAVLink peer on a real UDP socket inside the running event loop: a ground station for
flights on the simulated clock (:mod:`tests.support.simulated`), where a blocking pymavlink
read would stop the clock. What :class:`tests.support.harness.MavClient` is on the wall
clock: messages are read in order, and each ``recv`` consumes what it passes over."""

from __future__ import annotations

import asyncio
import os
import socket
from collections import deque
from collections.abc import Callable
from typing import Any

os.environ.setdefault("MAVLINK20", "1")

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.clock import now_s
from tests.support.mavmsgs import TextPane


class _Sender:
    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock

    def write(self, data: bytes) -> None:
        self.sock.send(data)


class LoopMav:
    """``udpout`` to ``port`` on 127.0.0.1 as system ``sysid``/``compid``, read by the loop."""

    def __init__(self, port: int, sysid: int, compid: int = 190) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setblocking(False)
        self.sock.connect(("127.0.0.1", port))
        self.mav = mavlink.MAVLink(_Sender(self.sock), srcSystem=sysid, srcComponent=compid)
        self.mav.robust_parsing = True
        self.inbox: deque[Any] = deque()  # read from the left: a long day's inbox stays cheap
        self.texts: list[str] = []  # every STATUSTEXT seen (chunks joined)
        self._pane = TextPane(self.texts)
        self._changed = asyncio.Event()
        self._loop = asyncio.get_running_loop()
        self._loop.add_reader(self.sock.fileno(), self._readable)
        self.heartbeat()

    def close(self) -> None:
        self._loop.remove_reader(self.sock.fileno())
        self.sock.close()

    def _readable(self) -> None:
        while True:
            try:
                data = self.sock.recv(65535)
            except (BlockingIOError, ConnectionRefusedError):
                return
            for msg in self.mav.parse_buffer(data) or []:
                if msg.get_type() == "BAD_DATA":
                    continue
                if msg.get_type() == "STATUSTEXT":
                    self._pane.note(msg)
                self.inbox.append(msg)
            self._changed.set()

    def heartbeat(self) -> None:
        self.mav.heartbeat_send(6, 8, 0, 0, 0)  # MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID

    def drain(self) -> None:
        """Forget what arrived so far (as reading it all would)."""
        self.inbox.clear()

    async def recv(
        self, kind: str, timeout_s: float, condition: Callable[[Any], bool] | None = None
    ) -> Any | None:
        """Next message of ``kind`` satisfying ``condition`` within ``timeout_s`` (simulated);
        the messages before it are consumed."""
        deadline = now_s() + timeout_s
        while (remaining := deadline - now_s()) > 0:
            msg = await self.recv_any((kind,), remaining)
            if msg is not None and (condition is None or condition(msg)):
                return msg
        return None

    async def recv_any(self, kinds: tuple[str, ...], timeout_s: float) -> Any | None:
        """Next message of any of ``kinds`` within ``timeout_s`` (simulated)."""
        deadline = now_s() + timeout_s
        while True:
            while self.inbox:
                msg = self.inbox.popleft()
                if msg.get_type() in kinds:
                    return msg
            remaining = deadline - now_s()
            if remaining <= 0:
                return None
            self._changed.clear()
            try:
                await asyncio.wait_for(self._changed.wait(), remaining)
            except TimeoutError:
                return None

    async def expect(
        self, kind: str, timeout_s: float, condition: Callable[[Any], bool] | None = None
    ) -> Any:
        msg = await self.recv(kind, timeout_s, condition)
        assert msg is not None, f"no {kind} within {timeout_s} s"
        return msg

    async def wait_text(self, prefix: str, timeout_s: float) -> str:
        """A STATUSTEXT starting with ``prefix`` seen so far or arriving within the timeout."""
        deadline = now_s() + timeout_s
        while True:
            for text in self.texts:
                if text.startswith(prefix):
                    return text
            remaining = deadline - now_s()
            if remaining <= 0:
                raise AssertionError(f"no STATUSTEXT {prefix!r}; saw {self.texts}")
            await self.recv("STATUSTEXT", remaining)

    async def command(
        self,
        command: int,
        *params: float,
        target: tuple[int, int] = (1, 1),
        timeout_s: float = 10.0,
    ) -> int:
        """COMMAND_LONG to ``target``; the result of its COMMAND_ACK, matched by the command
        and the component that was addressed (as QGroundControl matches it)."""
        p = [float(x) for x in params] + [0.0] * (7 - len(params))
        self.drain()
        self.mav.command_long_send(target[0], target[1], command, 0, *p)
        ack = await self.expect(
            "COMMAND_ACK",
            timeout_s,
            lambda m: (
                int(m.command) == command and (m.get_srcSystem(), m.get_srcComponent()) == target
            ),
        )
        return int(ack.result)
