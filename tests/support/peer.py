"""A scriptable autopilot for the link tests: pymavlink on a real socket, in its own thread.

It behaves like ArduPilot Rover where helixd cares (docs/ardupilot.md): HEARTBEAT (GROUND_ROVER,
ARDUPILOTMEGA, custom_mode), message intervals (DENIED below ``min_interval_us``, 25 ms like
Rover's 50 Hz loop; slow default streams until asked), ARM with a "PreArm: …" STATUSTEXT
before FAILED, DO_SET_MODE, DO_SET_SERVO with the SERVOn_FUNCTION rule, REQUEST_MESSAGE for
GPS_GLOBAL_ORIGIN, PARAM_REQUEST_READ/PARAM_SET (silence for unknown names), UNSUPPORTED for
anything else. Tests script it: answer a command late, twice, never, or with any result; slow a
stream; reboot (time_boot_ms restarts); stop and start again on the same port; speak as another
system. Everything it receives is recorded with ``time.monotonic()`` (the same clock asyncio
uses), e.g. every RC_CHANNELS_OVERRIDE.

Wires: UDP (sends to helixd's udpin port and answers the last sender), TCP server (helixd
connects with tcp:), and a pseudo-terminal behind a symlink (helixd opens it as a serial port;
``stop()`` makes the "device" vanish, ``start()`` brings it back under the same name).
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import os
import select
import socket
import threading
import time
import tty
from collections import deque
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.config.link import LinkConfig
from helixd.config.safety import SafetyConfig
from helixd.link.connection import Autopilot
from helixd.link.wire.signing import enable_signing
from helixd.mav.guard_script import PARAM_DEFAULTS as GUARD_PARAM_DEFAULTS
from helixd.mav.servo_functions import DO_SET_SERVO_FUNCTIONS
from tests.support.mavmsgs import EKF_HEALTHY_FLAGS

Address = tuple[str, int]

ACCEPTED = int(mavlink.MAV_RESULT_ACCEPTED)
DENIED = int(mavlink.MAV_RESULT_DENIED)
FAILED = int(mavlink.MAV_RESULT_FAILED)
UNSUPPORTED = int(mavlink.MAV_RESULT_UNSUPPORTED)
STREAM_NAMES = (
    "ATTITUDE",
    "LOCAL_POSITION_NED",
    "EKF_STATUS_REPORT",
    "SYS_STATUS",
    "RC_CHANNELS",
    "SERVO_OUTPUT_RAW",
    "MISSION_CURRENT",
    "GPS_RAW_INT",
)
MSG_NAME_BY_ID = {int(getattr(mavlink, f"MAVLINK_MSG_ID_{n}")): n for n in STREAM_NAMES}
HEARTBEAT_MSG_ID = int(mavlink.MAVLINK_MSG_ID_HEARTBEAT)
# granted but never sent: ArduPilot sends it only in a mode with a place to go
TARGET_MSG_ID = int(mavlink.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT)
HELIXD_SYSID = int(LinkConfig.model_fields["source_system"].default)
ROVER_PARAMS: dict[str, float] = {
    "MAV_GCS_SYSID": float(HELIXD_SYSID),  # set up for helixd (ArduPilot's default is 255)
    "RC_OVERRIDE_TIME": 3.0,
    "RC_OPTIONS": 32.0,
    "FS_GCS_ENABLE": 1.0,
    "MODE_CH": 8.0,
    "SCHED_LOOP_RATE": 50.0,  # Rover's default: 25 ms is the fastest interval granted
    **{f"SERVO{n}_FUNCTION": 0.0 for n in range(1, 17)},
    # helixd-guard installed and running (the script's own parameters, at their defaults)
    "SCR_ENABLE": 1.0,
    **GUARD_PARAM_DEFAULTS,
}


# Waiting is event-driven: the peer's thread announces every message it handled or sent, and
# until()/stays() re-check their predicate on each announcement. RECHECK_S bounds the wait for
# conditions that change on helixd's side without a message (a watchdog timer, a timeout).
RECHECK_S = 0.05
_watchers: list[tuple[asyncio.AbstractEventLoop, asyncio.Event]] = []
_watchers_lock = threading.Lock()


def announce_activity() -> None:
    """From any thread: wake every until()/stays() waiting now."""
    with _watchers_lock:
        watchers = list(_watchers)
    for loop, event in watchers:
        with contextlib.suppress(RuntimeError):  # that loop has closed meanwhile
            loop.call_soon_threadsafe(event.set)


@contextlib.contextmanager
def _watching() -> Any:
    entry = (asyncio.get_running_loop(), asyncio.Event())
    with _watchers_lock:
        _watchers.append(entry)
    try:
        yield entry[1]
    finally:
        with _watchers_lock:
            _watchers.remove(entry)


async def _next_activity(event: asyncio.Event, timeout_s: float) -> None:
    with contextlib.suppress(TimeoutError):
        await asyncio.wait_for(event.wait(), timeout_s)
    event.clear()


async def until(predicate: Callable[[], bool], timeout_s: float, what: str) -> None:
    """Wait until ``predicate`` holds; AssertionError naming ``what`` after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    with _watching() as activity:
        while not predicate():
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
            await _next_activity(activity, min(remaining, RECHECK_S))


async def stays(predicate: Callable[[], bool], duration_s: float, what: str) -> None:
    """``predicate`` holds for ``duration_s``; AssertionError naming ``what`` if it turns false."""
    deadline = time.monotonic() + duration_s
    with _watching() as activity:
        while True:
            if not predicate():
                raise AssertionError(f"{what} stopped holding")
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return
            await _next_activity(activity, min(remaining, RECHECK_S))


def free_port(kind: int = socket.SOCK_DGRAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


# ---------------------------------------------------------------------------------------------
# Wires


class Wire:
    def fds(self) -> list[int]:
        raise NotImplementedError

    def read(self, fd: int) -> list[bytes]:
        raise NotImplementedError

    def send(self, data: bytes) -> None:
        raise NotImplementedError

    def close(self) -> None:
        raise NotImplementedError

    @property
    def fresh_peer(self) -> bool:
        """True once after a new client connected (TCP): reset the parser."""
        return False


class UdpWire(Wire):
    def __init__(self, port: int, target: Address | None) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.sock.bind(("127.0.0.1", port))
        self.sock.setblocking(False)
        self.port = int(self.sock.getsockname()[1])
        self.target = target
        self.last_from: Address | None = None

    def fds(self) -> list[int]:
        return [self.sock.fileno()]

    def read(self, fd: int) -> list[bytes]:
        out: list[bytes] = []
        while True:
            try:
                data, addr = self.sock.recvfrom(65536)
            except (BlockingIOError, ConnectionRefusedError):
                return out
            self.last_from = addr
            out.append(data)

    def send(self, data: bytes) -> None:
        dest = self.target or self.last_from
        if dest is not None:
            # helixd not listening (yet): UDP drops it, as on a real network
            with contextlib.suppress(OSError):
                self.sock.sendto(data, dest)

    def close(self) -> None:
        self.sock.close()


class TcpServerWire(Wire):
    def __init__(self, port: int) -> None:
        self.server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.server.bind(("127.0.0.1", port))
        self.server.listen(1)
        self.server.setblocking(False)
        self.port = int(self.server.getsockname()[1])
        self.client: socket.socket | None = None
        self._fresh = False

    def fds(self) -> list[int]:
        fds = [self.server.fileno()]
        if self.client is not None:
            fds.append(self.client.fileno())
        return fds

    def read(self, fd: int) -> list[bytes]:
        if fd == self.server.fileno():
            conn, _ = self.server.accept()
            conn.setblocking(False)
            self.drop_client()
            self.client, self._fresh = conn, True
            return []
        assert self.client is not None
        try:
            data = self.client.recv(65536)
        except (BlockingIOError, ConnectionResetError):
            return []
        if not data:
            self.drop_client()
            return []
        return [data]

    @property
    def fresh_peer(self) -> bool:
        fresh, self._fresh = self._fresh, False
        return fresh

    def drop_client(self) -> None:
        if self.client is not None:
            self.client.close()
            self.client = None

    def send(self, data: bytes) -> None:
        if self.client is not None:
            try:
                self.client.sendall(data)
            except OSError:
                self.drop_client()

    def close(self) -> None:
        self.drop_client()
        self.server.close()


class PtyWire(Wire):
    """A pseudo-terminal whose slave is reachable as ``link_path`` (a udev-like symlink)."""

    def __init__(self, link_path: Path) -> None:
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)  # no echo of our own bytes before helixd configures it
        os.set_blocking(self.master, False)
        self.link_path = link_path
        link_path.unlink(missing_ok=True)
        link_path.symlink_to(os.ttyname(self.slave))

    def fds(self) -> list[int]:
        return [self.master]

    def read(self, fd: int) -> list[bytes]:
        try:
            return [os.read(self.master, 65536)]
        except (BlockingIOError, OSError):
            return []

    def send(self, data: bytes) -> None:
        # nobody reading and the pty buffer full: a serial line would drop it too
        with contextlib.suppress(OSError):
            os.write(self.master, data)

    def close(self) -> None:
        self.link_path.unlink(missing_ok=True)
        os.close(self.master)
        os.close(self.slave)


# ---------------------------------------------------------------------------------------------
# The autopilot


@dataclass
class Reply:
    """How to answer a COMMAND_LONG. ``result=None`` never answers."""

    result: int | None = ACCEPTED
    delay_s: float = 0.0
    copies: int = 1
    copy_gap_s: float = 0.0


@dataclass
class CommandRecord:
    t: float
    command: int
    params: tuple[float, ...]
    confirmation: int
    sysid: int


@dataclass
class OverrideRecord:
    t: float
    sysid: int
    values: tuple[int, ...]


@dataclass
class PeerRecords:
    commands: list[CommandRecord] = field(default_factory=list)
    overrides: list[OverrideRecord] = field(default_factory=list)
    gcs_heartbeats: list[tuple[float, int, int]] = field(default_factory=list)  # t, sysid, type
    param_sets: list[tuple[str, float]] = field(default_factory=list)
    signed_rx: int = 0
    unsigned_rx: int = 0

    def commands_of(self, command: int, after_t: float = 0.0) -> list[CommandRecord]:
        return [c for c in list(self.commands) if c.command == command and c.t >= after_t]


class AutopilotPeer:
    """See the module docstring. ``start()``/``stop()`` from the test thread; it runs alone."""

    def __init__(
        self,
        wire_factory: Callable[[int], Wire],
        *,
        sysid: int = 1,
        compid: int = 1,
        heartbeat_hz: float = 10.0,
        min_interval_us: int = 25_000,
        default_interval_us: int = 1_000_000,
        signing_key: bytes | None = None,
    ) -> None:
        self._wire_factory = wire_factory
        self.sysid, self.compid = sysid, compid
        self.heartbeat_hz = heartbeat_hz
        self.heartbeat_asked_us: int | None = None  # SET_MESSAGE_INTERVAL for HEARTBEAT
        self.min_interval_us = min_interval_us
        self.default_interval_us = default_interval_us
        self.signing_key = signing_key
        self.port = 0
        self.params = dict(ROVER_PARAMS)
        self.records = PeerRecords()
        self.replies: dict[int, Reply] = {}
        self.reply_queue: dict[int, deque[Reply]] = {}
        self.rate_cap_hz: dict[str, float] = {}
        self.prearm_text: str | None = None
        self.origin: tuple[float, float] | None = (45.0, -73.0)
        self.ekf_flags = EKF_HEALTHY_FLAGS
        self.armed = False
        self.custom_mode = 0
        self.rc_in = [1500] * 4 + [1000] * 14
        self.servo_out = [1500] * 16
        self.intervals_us: dict[str, int] = {}
        self.wire: Wire | None = None
        self._boot_t = time.monotonic()
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._outbox: deque[tuple[float, bytes]] = deque()
        self._calls: deque[Callable[[], None]] = deque()
        self._due: dict[str, float] = {}
        self._tx = self._codec(sysid, compid)
        self._rx = self._codec(0, 0)
        self._reset_streams()

    # -- control (test thread) ----------------------------------------------------------------

    def start(self) -> None:
        assert self._thread is None, "already running"
        self.wire = self._wire_factory(self.port)
        self.port = getattr(self.wire, "port", self.port)
        self._rx = self._codec(0, 0)
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="autopilot-peer", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        if self._thread is None:
            return
        self._stop.set()
        self._thread.join(timeout=5)
        self._thread = None
        if self.wire is not None:
            self.wire.close()
            self.wire = None

    def reboot(self) -> None:
        """time_boot_ms restarts at 0, streams fall back to their defaults, INITIALISING."""
        self._boot_t = time.monotonic()
        self.armed = False
        self.custom_mode = 16
        self._reset_streams()

    def set_reply(self, command: int, reply: Reply | None) -> None:
        if reply is None:
            self.replies.pop(command, None)
        else:
            self.replies[command] = reply

    def queue_replies(self, command: int, *replies: Reply) -> None:
        """One scripted reply per COMMAND_LONG received (re-sends included), then defaults."""
        self.reply_queue.setdefault(command, deque()).extend(replies)

    def send_as(self, sysid: int, compid: int, build: Callable[[Any], Any]) -> None:
        """Queue ``build(codec)`` encoded as system ``sysid`` (e.g. another vehicle)."""
        codec = self._codec(sysid, compid)
        self._outbox.append((time.monotonic(), bytes(build(codec).pack(codec))))

    def call_soon(self, fn: Callable[[Wire], None]) -> None:
        """Run ``fn(wire)`` in the peer thread (e.g. drop the TCP client)."""
        self._calls.append(lambda: fn(self.wire) if self.wire is not None else None)

    def statustext(self, text: str, severity: int = 4) -> None:
        self._queue(self._tx.statustext_encode(severity, text.encode()), 0.0)

    # -- internals (peer thread) --------------------------------------------------------------

    def _codec(self, sysid: int, compid: int) -> Any:
        codec = mavlink.MAVLink(None, srcSystem=sysid, srcComponent=compid)
        codec.robust_parsing = True
        if self.signing_key is not None:
            enable_signing(codec, self.signing_key)
            codec.signing.allow_unsigned_callback = lambda *_: True
        return codec

    def _reset_streams(self) -> None:
        self.intervals_us = dict.fromkeys(STREAM_NAMES, self.default_interval_us)
        now = time.monotonic()
        self._due = dict.fromkeys([*STREAM_NAMES, "HEARTBEAT"], now)
        self._mode_settles_t = now + 0.3

    def _queue(self, msg: Any, delay_s: float) -> None:
        buf = bytes(msg.pack(self._tx))
        self._tx.seq = (self._tx.seq + 1) % 256
        self._outbox.append((time.monotonic() + delay_s, buf))

    def _run(self) -> None:
        wire = self.wire
        assert wire is not None
        while not self._stop.is_set():
            now = time.monotonic()
            nxt = min([*self._due.values(), *(t for t, _ in self._outbox), now + 0.005])
            while self._calls:
                self._calls.popleft()()
            readable, _, _ = select.select(wire.fds(), [], [], max(0.0, nxt - now))
            for fd in readable:
                for data in wire.read(fd):
                    if wire.fresh_peer:
                        self._rx = self._codec(0, 0)
                    for msg in self._rx.parse_buffer(data) or []:
                        self._handle(msg, time.monotonic())
            self._emit(time.monotonic())
            now = time.monotonic()
            pending = [item for item in self._outbox if item[0] <= now]
            for item in pending:
                self._outbox.remove(item)
                wire.send(item[1])
            if readable or pending:
                announce_activity()

    def _boot_ms(self, now: float) -> int:
        return int((now - self._boot_t) * 1000)

    def _emit(self, now: float) -> None:
        if self.custom_mode == 16 and now >= self._mode_settles_t:
            self.custom_mode = 0  # INITIALISING → MANUAL, as Rover does after boot
        if now >= self._due["HEARTBEAT"]:
            self._due["HEARTBEAT"] = now + 1.0 / self.heartbeat_hz
            base = 1 | (128 if self.armed else 0)
            self._queue(self._tx.heartbeat_encode(10, 3, base, self.custom_mode, 4), 0.0)
        for name in STREAM_NAMES:
            interval = self.intervals_us.get(name, 0)
            if interval <= 0 or now < self._due[name]:
                continue
            period = interval / 1e6
            cap = self.rate_cap_hz.get(name)
            if cap is not None:
                period = max(period, 1.0 / cap)
            self._due[name] = now + period
            self._queue(self._stream_msg(name, now), 0.0)
        for name in STREAM_NAMES:
            if self.intervals_us.get(name, 0) <= 0:
                self._due[name] = now + 1.0

    def _stream_msg(self, name: str, now: float) -> Any:
        t_ms = self._boot_ms(now)
        tx = self._tx
        s = now - self._boot_t
        if name == "ATTITUDE":
            return tx.attitude_encode(
                t_ms, 0.0, 0.0, math.remainder(0.1 * s, 2 * math.pi), 0.0, 0.0, 0.1
            )
        if name == "LOCAL_POSITION_NED":
            return tx.local_position_ned_encode(t_ms, 0.1 * s, 0.05 * s, 0.0, 0.1, 0.05, 0.0)
        if name == "EKF_STATUS_REPORT":
            return tx.ekf_status_report_encode(self.ekf_flags, 0.1, 0.1, 0.1, 0.1, 0.0)
        if name == "SYS_STATUS":
            return tx.sys_status_encode(0, 0, 0, 100, 12600, -1, -1, 0, 0, 0, 0, 0, 0)
        if name == "RC_CHANNELS":
            return tx.rc_channels_encode(t_ms, 8, *self.rc_in, 255)
        if name == "MISSION_CURRENT":
            return tx.mission_current_encode(0, 0, 1, 0)  # MISSION_STATE_NO_MISSION
        if name == "GPS_RAW_INT":  # a 3D fix with 12 satellites
            return tx.gps_raw_int_encode(t_ms * 1000, 3, 0, 0, 0, 100, 200, 0, 0, 12)
        return tx.servo_output_raw_encode(t_ms * 1000 % 2**32, 0, *self.servo_out)

    def _handle(self, msg: Any, now: float) -> None:
        mtype = msg.get_type()
        if mtype == "BAD_DATA":
            return
        src = int(msg.get_srcSystem())
        rec = self.records
        if msg.get_signed():
            rec.signed_rx += 1
        else:
            rec.unsigned_rx += 1
        if mtype == "HEARTBEAT":
            rec.gcs_heartbeats.append((now, src, int(msg.type)))
        elif mtype == "RC_CHANNELS_OVERRIDE":
            values = tuple(int(getattr(msg, f"chan{i}_raw")) for i in range(1, 19))
            rec.overrides.append(OverrideRecord(now, src, values))
        elif mtype == "COMMAND_LONG" and int(msg.target_system) == self.sysid:
            self._command(msg, now)
        elif mtype == "PARAM_REQUEST_READ" and int(msg.target_system) == self.sysid:
            self._param_value(str(msg.param_id))
        elif mtype == "PARAM_SET" and int(msg.target_system) == self.sysid:
            name = str(msg.param_id)
            rec.param_sets.append((name, float(msg.param_value)))
            if name in self.params:
                self.params[name] = float(msg.param_value)
                self._param_value(name)

    def _param_value(self, name: str) -> None:
        if name in self.params:
            names = list(self.params)
            msg = self._tx.param_value_encode(
                name.encode(), self.params[name], 9, len(names), names.index(name)
            )
            self._queue(msg, 0.0)

    def _command(self, msg: Any, now: float) -> None:
        cmd = int(msg.command)
        params = tuple(float(getattr(msg, f"param{i}")) for i in range(1, 8))
        self.records.commands.append(
            CommandRecord(now, cmd, params, int(msg.confirmation), int(msg.get_srcSystem()))
        )
        queue = self.reply_queue.get(cmd)
        reply = queue.popleft() if queue else self.replies.get(cmd)
        if reply is None:
            reply = Reply(result=self._default_result(cmd, params))
        if reply.result is None:
            return
        for i in range(reply.copies):
            ack = self._tx.command_ack_encode(
                cmd, reply.result, 0, 0, int(msg.get_srcSystem()), int(msg.get_srcComponent())
            )
            self._queue(ack, reply.delay_s + i * reply.copy_gap_s)

    def _default_result(self, cmd: int, p: tuple[float, ...]) -> int:
        if cmd == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL:
            name = MSG_NAME_BY_ID.get(int(p[0]))
            interval = int(p[1])
            if int(p[0]) == TARGET_MSG_ID and not 0 < interval < self.min_interval_us:
                return ACCEPTED
            if int(p[0]) == HEARTBEAT_MSG_ID and interval > 0:
                # granted; the peer's HEARTBEAT (heartbeat_hz, 10 Hz) is already faster
                self.heartbeat_asked_us = interval
                return ACCEPTED
            if name is None:
                return UNSUPPORTED
            if 0 < interval < self.min_interval_us:
                return DENIED
            self.intervals_us[name] = self.default_interval_us if interval == 0 else interval
            self._due[name] = time.monotonic()
            return ACCEPTED
        if cmd == mavlink.MAV_CMD_COMPONENT_ARM_DISARM:
            if int(p[0]) == 1:
                if self.prearm_text and int(p[1]) != 21196:
                    self.statustext(self.prearm_text, severity=2)
                    return FAILED
                self.armed = True
            else:
                self.armed = False
            return ACCEPTED
        if cmd == mavlink.MAV_CMD_DO_SET_MODE:
            self.custom_mode = int(p[1])
            return ACCEPTED
        if cmd == mavlink.MAV_CMD_DO_SET_SERVO:
            channel, pwm = int(p[0]), int(p[1])
            function = int(self.params.get(f"SERVO{channel}_FUNCTION", 0))
            if not 1 <= channel <= 16 or function not in DO_SET_SERVO_FUNCTIONS:
                return FAILED
            self.servo_out[channel - 1] = pwm
            return ACCEPTED
        if cmd == mavlink.MAV_CMD_REQUEST_MESSAGE:
            if int(p[0]) == mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN and self.origin is not None:
                lat, lon = self.origin
                self._queue(
                    self._tx.gps_global_origin_encode(round(lat * 1e7), round(lon * 1e7), 0), 0.0
                )
                return ACCEPTED
            return FAILED
        return UNSUPPORTED


def udp_peer(target: Address, **kwargs: Any) -> AutopilotPeer:
    return AutopilotPeer(lambda port: UdpWire(port, target), **kwargs)


def tcp_peer(**kwargs: Any) -> AutopilotPeer:
    return AutopilotPeer(TcpServerWire, **kwargs)


def pty_peer(link_path: Path, **kwargs: Any) -> AutopilotPeer:
    return AutopilotPeer(lambda _port: PtyWire(link_path), **kwargs)


# ---------------------------------------------------------------------------------------------
# helixd side of a test


def link_config(**overrides: Any) -> LinkConfig:
    """Fast settings for tests: short command timeouts, quick reconnects and checks."""
    base: dict[str, Any] = {
        "url": "udpin:127.0.0.1:0",
        "command_timeout_s": 0.25,
        "command_retries": 2,
        "reconnect_interval_s": 0.2,
        "stream_check_window_s": 0.5,
        "statustext_grace_s": 0.3,
    }
    base.update(overrides)
    return LinkConfig(**base)


def safety_config(**overrides: Any) -> SafetyConfig:
    base: dict[str, Any] = {"heartbeat_timeout_s": 0.5}
    base.update(overrides)
    return SafetyConfig(**base)


@contextlib.asynccontextmanager
async def linked(
    *,
    peer_kwargs: dict[str, Any] | None = None,
    safety: SafetyConfig | None = None,
    **cfg_overrides: Any,
) -> AsyncIterator[tuple[Autopilot, AutopilotPeer]]:
    """helixd listening on udpin:127.0.0.1:<free>, the peer sending to it; heartbeat seen."""
    ap = await Autopilot.connect(link_config(**cfg_overrides), safety or safety_config())
    address = ap.local_address
    assert address is not None
    peer = udp_peer(address, **(peer_kwargs or {}))
    peer.start()
    try:
        await ap.wait_heartbeat(5.0)
        yield ap, peer
    finally:
        peer.stop()
        await ap.close()
