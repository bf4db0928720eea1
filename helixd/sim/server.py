"""I/O shell of the simulator: MAVLink links, wall-clock pacing, a background thread.

The core (:class:`helixd.sim.core.SimCore`) is stepped on the simulator thread's asyncio
loop at SCHED_LOOP_RATE in *simulated* time; simulated time runs ``speedup`` times faster
than wall time (SITL's --speedup), and message rates are in simulated time, as SITL's are.
When the machine cannot keep up, simulated time slows down rather than skipping loops, and
while the rover is armed a machine that does not keep the asked speed-up is said so at once
and the speed-up lowered to what it kept (:mod:`helixd.sim.pace`): a flight whose poses and
commands arrive late in simulated time is another flight.

Links are pymavlink-style strings: ``udpin:HOST:PORT`` (bind; reply to whoever spoke last),
``udpout:HOST:PORT`` (send there, listen on the same socket), ``tcpin:HOST:PORT`` (serve
TCP clients, like SITL's tcp:5760). Each link has its own message intervals. Messages are
forwarded between links as ArduPilot's MAVLink_routing does (:class:`helixd.sim.inbound.Router`):
a ground station on one link is heard on the others.

The autopilot's working directory (``SimConfig.workdir``, or a temporary directory made for
the run and removed at :meth:`SimServer.stop`) is SITL's: MAVLink FTP serves it
(:class:`helixd.sim.ftp_server.FtpServer`, as ArduPilot's GCS_FTP over ``AP_Filesystem``), and the
Lua scripts in its ``scripts/`` are read when the autopilot boots. With
``guard_installed`` the shell writes helixd-guard.lua there before the first boot.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import os
import shutil
import tempfile
import threading
import time
from collections.abc import AsyncIterator, Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np
import structlog

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.clock import now_s, on_simulated_clock
from helixd.files.media import read_media_map
from helixd.mav.guard_script import POSIX_SCRIPTS_DIR, SCRIPT_NAME, script_bytes
from helixd.sim.core import SimCore
from helixd.sim.faults import make_spec
from helixd.sim.firmware.param_store import ParamStore
from helixd.sim.ftp_server import FtpServer
from helixd.sim.inbound import Router
from helixd.sim.pace import PaceJudge
from helixd.sim.sim_config import SimConfig
from helixd.sim.snapshot import History, HistoryEntry, SimSnapshot, take_snapshot
from helixd.sim.storage import read_storage, storage_values, with_storage, write_storage

log = structlog.get_logger(__name__)

LOGGED_KINDS = frozenset(
    {"mode", "arm", "disarm", "failsafe", "failsafe_cleared", "fault", "fault_end", "boot",
     "reboot", "statustext"}
)  # fmt: skip
# In-process (helixd run --sim) helixd logs what it sees of these itself (autopilot_mode,
# autopilot_statustext, armed): the simulator's own copies go to debug there.
# (and its boot and reboots: autopilot_heartbeat, autopilot_rebooted). Its own start, stop and
# link peers go to debug there too: helixd's console is the run's, ending in its RESULT line.
ECHOED_BY_HELIXD_KINDS = frozenset({"mode", "arm", "disarm", "statustext", "boot", "reboot"})
MAX_LOOPS_PER_WAKEUP = 50
MIN_SLEEP_S = 0.0005
START_TIMEOUT_S = 10.0
CALL_TIMEOUT_S = 10.0
ERROR_LOG_INTERVAL_S = 10.0


@dataclass(frozen=True, slots=True)
class LinkSpec:
    kind: str  # "udpin" | "udpout" | "tcpin"
    host: str
    port: int

    @staticmethod
    def parse(url: str) -> LinkSpec:
        kind, sep, rest = url.partition(":")
        host, sep2, port_text = rest.rpartition(":")
        kind = {"udp": "udpin"}.get(kind, kind)
        if not sep or not sep2 or kind not in ("udpin", "udpout", "tcpin") or not host:
            raise ValueError(
                f"{url!r}: expected udpin:HOST:PORT, udpout:HOST:PORT or tcpin:HOST:PORT"
            )
        try:
            port = int(port_text)
        except ValueError:
            raise ValueError(f"{url!r}: port {port_text!r} is not a number") from None
        if not 0 <= port <= 65535 or (port == 0 and kind == "udpout"):
            raise ValueError(f"{url!r}: bad port {port}")
        return LinkSpec(kind, host, port)


class _PackBuffer:
    """File-like object pymavlink writes packed messages into."""

    def __init__(self) -> None:
        self.chunks: list[bytes] = []

    def write(self, data: bytes) -> None:
        self.chunks.append(bytes(data))

    def take(self) -> list[bytes]:
        out, self.chunks = self.chunks, []
        return out


class _Link(asyncio.DatagramProtocol, asyncio.Protocol):
    """One MAVLink link: parser, encoder and transport(s)."""

    def __init__(
        self,
        index: int,
        spec: LinkSpec,
        on_bytes: Callable[[int, bytes], None],
        embedded: bool = False,
    ) -> None:
        self.index = index
        self.embedded = embedded
        self.spec = spec
        self.on_bytes = on_bytes
        self.sink = _PackBuffer()
        self.mav = mavlink.MAVLink(self.sink, srcSystem=1, srcComponent=1)
        self.mav.robust_parsing = True
        self.udp: asyncio.DatagramTransport | None = None
        self.peer: tuple[str, int] | None = None
        self.tcp_clients: list[asyncio.Transport] = []
        self.server: asyncio.Server | None = None
        self.local_port = 0
        self.errors = 0
        self.last_error_log_s = -ERROR_LOG_INTERVAL_S
        self.deaf = False  # its peer's process is gone (cut_peer): nothing heard from it

    # datagram side
    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        # (3.11's selector datagram transport is not an asyncio.DatagramTransport subclass)
        if self.spec.kind == "tcpin":
            self.tcp_clients.append(cast(asyncio.Transport, transport))
        else:
            self.udp = cast(asyncio.DatagramTransport, transport)

    def datagram_received(self, data: bytes, addr: tuple[str, int]) -> None:
        if self.deaf:
            return
        if self.spec.kind == "udpin" and addr != self.peer:
            self.peer = addr
            emit = log.debug if self.embedded else log.info
            emit("sim_link_peer", link=self.index, peer=f"{addr[0]}:{addr[1]}")
        self.on_bytes(self.index, data)

    def error_received(self, exc: Exception) -> None:
        # e.g. ICMP port unreachable on a udpout link nobody listens to yet: say so, rarely
        self.errors += 1
        now = now_s()
        if now - self.last_error_log_s >= ERROR_LOG_INTERVAL_S:
            self.last_error_log_s = now
            log.warning("sim_link_error", link=self.index, error=str(exc), count=self.errors)

    # stream side (tcpin clients share this protocol object)
    def data_received(self, data: bytes) -> None:
        self.on_bytes(self.index, data)

    def connection_lost(self, exc: Exception | None) -> None:
        self.tcp_clients = [t for t in self.tcp_clients if not t.is_closing()]

    def send(self, msg: mavlink.MAVLink_message, sysid: int) -> None:
        self.mav.srcSystem = sysid
        self.mav.send(msg)
        for data in self.sink.take():
            self.send_raw(data)

    def send_raw(self, data: bytes) -> None:
        """Put a packed frame on the wire as it is (forwarding keeps the sender's ids)."""
        if self.udp is not None:
            if self.spec.kind == "udpout":
                self.udp.sendto(data)
            elif self.peer is not None:
                self.udp.sendto(data, self.peer)
        for client in self.tcp_clients:
            if not client.is_closing():
                client.write(data)

    def close(self) -> None:
        if self.udp is not None:
            self.udp.close()
        for client in self.tcp_clients:
            client.close()
        if self.server is not None:
            self.server.close()


class SimServer:
    """The simulator running on its own thread, reachable over MAVLink links."""

    def __init__(
        self,
        links: Sequence[str],
        config: SimConfig,
        embedded: bool = False,
        judge_pace: bool = False,
    ) -> None:
        if not links:
            raise ValueError("at least one link is needed")
        self.link_specs = [LinkSpec.parse(url) for url in links]
        config = with_media(config)
        self.config = config
        self._quiet_kinds = ECHOED_BY_HELIXD_KINDS if embedded else frozenset()
        self._embedded = embedded
        self.history = History(config.history_max_entries)
        rng = np.random.default_rng(config.seed)
        self._own_workdir = config.workdir is None
        self.workdir = prepare_workdir(config)
        self._ftp = FtpServer(self.workdir)
        # a working directory of its own keeps the parameter storage across restarts
        boot_config = (
            config if self._own_workdir else with_storage(config, read_storage(self.workdir))
        )
        self._core = SimCore(
            boot_config,
            len(self.link_specs),
            rng,
            ftp=self._ftp,
            scripts=lambda: read_scripts(self.workdir),
        )
        self._stored_version = self._core.params.version
        self._param_defaults = ParamStore(dict(config.params)).as_dict()
        self._router = Router()
        self._links: list[_Link] = []
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._ready = threading.Event()
        self._stopping = threading.Event()
        self._startup_error: BaseException | None = None
        self._cond = threading.Condition()
        self._snapshot = take_snapshot(self._core)
        # called on the simulator's loop with each snapshot it publishes (a recorder's trace)
        self.snapshot_listeners: list[Callable[[SimSnapshot], None]] = []
        self.local_ports: list[int] = []
        # the wall-clock pace: the speed-up kept now, judged per window (helixd.sim.pace)
        self._speedup = config.speedup
        self._pace = PaceJudge(self._core.dt_s())
        self._pace_warned = False
        # judged only when asked (helixd run/serve --sim: a flight that must be the flight);
        # never on a simulated clock shared with the daemon (running_here), which has no pace
        self._judge = judge_pace
        # called after every loop on the wall clock: a test's seam for a slow machine (a loop
        # that costs more wall time than this one's), never set in production
        self.after_tick: Callable[[], None] | None = None
        self._coarse = False  # quiet steps of several loops (_run: on a simulated clock)
        # while the loop waits out a quiet step: the future an input sets (_catch_up)
        self._wake: asyncio.Future[None] | None = None

    # -- lifecycle -------------------------------------------------------------------------

    def start(self) -> None:
        """Start the thread; returns once every link is bound (raises if one cannot be)."""
        if self._thread is not None:
            raise RuntimeError("SimServer already started")
        self._thread = threading.Thread(target=self._thread_main, name="helixd-sim", daemon=True)
        self._thread.start()
        if not self._ready.wait(START_TIMEOUT_S):
            raise RuntimeError("simulator did not start within 10 s")
        if self._startup_error is not None:
            self._thread.join(timeout=START_TIMEOUT_S)
            raise RuntimeError(f"simulator failed to start: {self._startup_error}") from (
                self._startup_error
            )

    def stop(self) -> None:
        self._stopping.set()
        if self._thread is not None:
            self._thread.join(timeout=START_TIMEOUT_S)
            if self._thread.is_alive():
                log.error("sim_stop_timeout")
                return  # the thread may still use the FTP server and the directory
        self._release()

    def _release(self) -> None:
        self._ftp.close()
        if self._own_workdir:
            shutil.rmtree(self.workdir, ignore_errors=True)

    def __enter__(self) -> SimServer:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _thread_main(self) -> None:
        loop = asyncio.new_event_loop()
        self._loop = loop
        try:
            loop.run_until_complete(self._main())
        except Exception as exc:  # reported to start() or logged; the thread must not die silently
            if not self._ready.is_set():
                self._startup_error = exc
                self._ready.set()
            else:
                log.exception("sim_crashed", error=str(exc))
        finally:
            loop.close()
            with self._cond:
                self._cond.notify_all()

    async def _main(self) -> None:
        try:
            await self._open_links()
            self._ready.set()
            await self._run()
        finally:
            self._close_links()

    @contextlib.asynccontextmanager
    async def running_here(self) -> AsyncIterator[SimServer]:
        """Run in the caller's event loop instead of a thread of its own: on a
        :class:`helixd.base.clock.SimulatedClockLoop` the simulator and the daemon then share
        one simulated clock. Links are bound on entry; on exit the simulator stops."""
        if self._thread is not None or self._loop is not None:
            raise RuntimeError("SimServer already started")
        self._loop = asyncio.get_running_loop()
        self._judge = self._judge and not on_simulated_clock()
        try:
            await self._open_links()
        except BaseException:
            self._close_links()
            self._release()
            raise
        self._ready.set()
        task = asyncio.create_task(self._run(), name="helixd-sim")
        try:
            yield self
        finally:
            self._stopping.set()
            try:
                await task
            finally:
                self._close_links()
                self._release()
                with self._cond:
                    self._cond.notify_all()

    async def _open_links(self) -> None:
        loop = asyncio.get_running_loop()
        for i, spec in enumerate(self.link_specs):
            self._links.append(await self._open(loop, i, spec))
        self.local_ports = [link.local_port for link in self._links]
        (log.debug if self._embedded else log.info)(
            "sim_started",
            links=[
                f"{s.kind}:{s.host}:{p}"
                for s, p in zip(self.link_specs, self.local_ports, strict=True)
            ],
            speedup=self.config.speedup,
            plant=self.config.plant.value,
            terrain=self.config.terrain.value,
            media=None if self.config.media is None else self.config.media.source,
            noise=self.config.noise.value,
        )

    def _close_links(self) -> None:
        for link in self._links:
            link.close()
        emit = log.debug if self._embedded else log.info
        emit("sim_stopped", sim_time_s=round(self._core.now_s, 3))

    async def _open(self, loop: asyncio.AbstractEventLoop, i: int, spec: LinkSpec) -> _Link:
        link = _Link(i, spec, self._on_bytes, self._embedded)
        if spec.kind == "udpin":
            transport, _ = await loop.create_datagram_endpoint(
                lambda: link, local_addr=(spec.host, spec.port)
            )
        elif spec.kind == "udpout":
            transport, _ = await loop.create_datagram_endpoint(
                lambda: link, remote_addr=(spec.host, spec.port)
            )
        else:
            link.server = await loop.create_server(lambda: link, spec.host, spec.port)
            link.local_port = int(link.server.sockets[0].getsockname()[1])
            return link
        link.local_port = int(transport.get_extra_info("sockname")[1])
        return link

    # -- the loop --------------------------------------------------------------------------

    @property
    def speedup(self) -> float:
        """The speed-up the simulator runs at now: the asked one, or lower once the machine
        could not keep it (:mod:`helixd.sim.pace`)."""
        return self._speedup

    async def _run(self) -> None:
        core = self._core
        start_wall, start_sim = now_s(), core.now_s
        # on a simulated clock a quiet autopilot takes several loops in one step (SimCore.
        # quiet_steps), woken early by any input (_catch_up); the wall's pace is loop by loop
        self._coarse = on_simulated_clock() and self._speedup == 1.0
        while not self._stopping.is_set():
            speedup = self._speedup
            target_sim = start_sim + (now_s() - start_wall) * speedup
            loops = 0
            steps = self._steps()
            while (
                core.now_s + steps * core.dt_s() <= target_sim + 1e-9
                and loops < MAX_LOOPS_PER_WAKEUP
            ):
                core.tick(steps)
                if self.after_tick is not None:
                    self.after_tick()
                self._after()
                loops += 1
                steps = self._steps()
            if loops == MAX_LOOPS_PER_WAKEUP:  # cannot keep up: slow simulated time down
                start_wall, start_sim = now_s(), core.now_s
            if self._judge_pace(loops):  # a lower speed-up from here on
                start_wall, start_sim = now_s(), core.now_s
            next_wall = start_wall + (core.now_s + steps * core.dt_s() - start_sim) / self._speedup
            if steps == 1:
                await asyncio.sleep(max(MIN_SLEEP_S, min(0.05, next_wall - now_s())))
                continue
            await self._quiet_wait(max(0.0, next_wall - now_s()))

    async def _quiet_wait(self, delay_s: float) -> None:
        """Wait out a quiet step, or less if an input comes first (_catch_up)."""
        loop = asyncio.get_running_loop()
        wake = self._wake = loop.create_future()
        timer = loop.call_later(delay_s, wake_up, wake)
        try:
            await wake
        finally:
            timer.cancel()
            self._wake = None

    def _steps(self) -> int:
        return self._core.quiet_steps() if self._coarse else 1

    def _catch_up(self) -> None:
        """An input in the middle of a quiet step: the loops that step would have taken
        before now, taken first (the input then meets the autopilot as it would have), and the
        loop woken to step loop by loop from here."""
        wake = self._wake
        if wake is None:
            return
        core = self._core
        behind = int((now_s() - core.now_s) / core.dt_s() + 1e-9)
        if behind >= 1 and core.quiet_steps() >= behind:
            core.tick(behind)
            self._after()
        wake_up(wake)

    def _judge_pace(self, loops: int) -> bool:
        """Did this wake-up end a window in which the machine did not keep the speed-up? Then
        say so at once (a warning and a ``pace`` history entry) and lower it (True)."""
        core = self._core
        if not self._judge or loops == 0:
            return False
        verdict = self._pace.wake(now_s(), core.now_s, loops, self._speedup, core.ap.armed)
        if verdict is None:
            return False
        details = {
            "asked_speedup": verdict.asked,
            "speedup": verdict.speedup,
            "loops_per_wakeup": round(verdict.loops_per_wakeup, 2),
            "achieved_speedup": round(verdict.achieved, 2),
        }
        if verdict.speedup >= verdict.asked:
            if not self._pace_warned:  # nothing lower to go to: said once
                self._pace_warned = True
                log.warning("sim_pace_not_kept", **details, why=verdict.reason())
                self.history.append(HistoryEntry(now_s(), core.now_s, "pace", details))
            return False
        log.warning(
            "sim_speedup_lowered",
            **details,
            why=f"{verdict.reason()}; flying on at {verdict.speedup:g} rather than another "
            "flight (late poses, late commands)",
        )
        self.history.append(HistoryEntry(now_s(), core.now_s, "pace", details))
        self._speedup = verdict.speedup
        return True

    def _on_bytes(self, index: int, data: bytes) -> None:
        link = self._links[index] if index < len(self._links) else None
        if link is None:
            return
        try:
            msgs = link.mav.parse_buffer(data) or []
        except mavlink.MAVError as exc:
            log.debug("sim_bad_packet", link=index, error=str(exc))
            return
        core = self._core
        self._catch_up()
        for msg in msgs:
            if msg.get_type() == "BAD_DATA":
                continue
            if core.link_up(index) and core.ap.accepts_from(int(msg.get_srcSystem())):
                for target in self._router.forward_links(index, msg, core.ap.sysid()):
                    if core.link_up(target):
                        self._links[target].send_raw(bytes(msg.get_msgbuf()))
            core.handle(index, msg)
        self._after()

    def _after(self) -> None:
        """Publish history and snapshot first, then put messages on the wire, so a client
        that saw a message can always find its cause in the history/snapshot."""
        core = self._core
        wall = now_s()
        for ev in core.drain_events():
            self.history.append(HistoryEntry(wall, core.now_s, ev.kind, dict(ev.details)))
            if ev.kind in LOGGED_KINDS:
                emit = log.debug if ev.kind in self._quiet_kinds else log.info
                emit(f"sim_{ev.kind}", sim_time_s=round(core.now_s, 3), **ev.details)
        snap = take_snapshot(core)
        with self._cond:
            self._snapshot = snap
            self._cond.notify_all()
        for listener in self.snapshot_listeners:
            listener(snap)
        if not self._own_workdir and core.params.version != self._stored_version:
            self._stored_version = core.params.version
            write_storage(self.workdir, storage_values(core.params, self._param_defaults))
        sysid = core.ap.sysid()
        for index, msg in core.drain_outbox():
            if index is not None:
                self._links[index].send(msg, sysid)

    # -- thread-safe API -------------------------------------------------------------------

    def _call(self, fn: Callable[[], Any]) -> Any:
        loop = self._loop
        if loop is not None and self._thread is None and not self._stopping.is_set():
            self._catch_up()
            result = fn()  # running here (running_here): the caller is on the loop's thread
            self._after()
            return result
        if loop is None or self._thread is None or not self._thread.is_alive():
            raise RuntimeError("simulator is not running")
        future: concurrent.futures.Future[Any] = concurrent.futures.Future()

        def run() -> None:
            try:
                future.set_result(fn())
                self._after()
            except Exception as exc:  # handed to the calling thread
                future.set_exception(exc)

        loop.call_soon_threadsafe(run)
        return future.result(timeout=CALL_TIMEOUT_S)

    def cut_peer(self, index: int = 0) -> Callable[[], None]:
        """The process behind link ``index`` is gone (a test's kill -9 of helixd in this
        process): nothing arriving on the link is heard (whatever socket the dead process's
        cleanup still sends from), nothing is sent until a new peer speaks. Returns what
        opens the link again, for the next process."""
        link = self._links[index] if index < len(self._links) else None
        if link is None:
            return lambda: None
        link.deaf, link.peer = True, None

        def hear_again() -> None:
            link.deaf = False

        return hear_again

    def snapshot(self) -> SimSnapshot:
        with self._cond:
            return self._snapshot

    def inject(self, fault: str, **kwargs: object) -> None:
        """Apply a fault now (see helixd.sim.faults.FAULTS for names and arguments)."""
        spec = make_spec(fault, kwargs)
        self._call(lambda: self._core.inject(spec))

    def schedule(self, fault: str, at_sim_s: float, **kwargs: object) -> None:
        spec = make_spec(fault, kwargs)
        self._call(lambda: self._core.schedule(spec, at_sim_s))

    def clear_fault(self, fault: str) -> None:
        self._call(lambda: self._core.clear_fault(fault))

    def set_rc(self, channel: int, pwm_us: int) -> None:
        """The simulated pilot's transmitter."""
        self._call(lambda: self._core.set_rc(channel, pwm_us))

    def wait_for(self, predicate: Callable[[SimSnapshot], bool], timeout_s: float) -> SimSnapshot:
        """Block until ``predicate(snapshot)`` holds; TimeoutError (with the last state) if not."""
        deadline = time.monotonic() + timeout_s
        with self._cond:
            while True:
                snap = self._snapshot
                if predicate(snap):
                    return snap
                remaining = deadline - time.monotonic()
                if remaining <= 0.0:
                    name = getattr(predicate, "__name__", "condition")
                    raise TimeoutError(
                        f"{name} not met within {timeout_s:.1f} s (wall); last: {snap.describe()}"
                    )
                if self._thread is None or not self._thread.is_alive():
                    raise TimeoutError(f"simulator stopped; last: {snap.describe()}")
                self._cond.wait(min(remaining, 0.2))

    def next_snapshot(self, previous: SimSnapshot | None, timeout_s: float) -> SimSnapshot:
        """The first snapshot published after ``previous`` (at once if ``previous`` is not the
        current one, e.g. None); TimeoutError if none comes within ``timeout_s`` (wall)."""
        deadline = time.monotonic() + timeout_s
        with self._cond:
            while self._snapshot is previous:
                remaining = deadline - time.monotonic()
                if remaining <= 0.0:
                    raise TimeoutError(f"no new snapshot within {timeout_s:.1f} s (wall)")
                if self._thread is None or not self._thread.is_alive():
                    raise TimeoutError(f"simulator stopped; last: {self._snapshot.describe()}")
                self._cond.wait(min(remaining, 0.2))
            return self._snapshot


def wake_up(future: asyncio.Future[None]) -> None:
    if not future.done():
        future.set_result(None)


def with_media(config: SimConfig) -> SimConfig:
    """``config`` with its ``media_file`` read into ``media`` (the shell's I/O). Raises
    :class:`helixd.files.media.MediaMapError` (one line per problem)."""
    if config.media_file is None:
        return config
    return config.model_copy(
        update={"media": read_media_map(config.media_file), "media_file": None}
    )


def prepare_workdir(config: SimConfig) -> Path:
    """The autopilot's working directory: ``config.workdir`` (made if missing) or a fresh
    temporary one; with ``guard_installed`` helixd-guard.lua is written into its scripts/."""
    if config.workdir is None:
        workdir = Path(tempfile.mkdtemp(prefix="helixd-sim-"))
    else:
        workdir = config.workdir
        workdir.mkdir(parents=True, exist_ok=True)
    if config.guard_installed:
        scripts = workdir / POSIX_SCRIPTS_DIR
        scripts.mkdir(exist_ok=True)
        (scripts / SCRIPT_NAME).write_bytes(script_bytes())
    return workdir.resolve()


def read_scripts(workdir: Path) -> dict[str, bytes]:
    """What AP_Scripting finds at boot: every ``*.lua`` in ``workdir/scripts`` (name → bytes)."""
    found: dict[str, bytes] = {}
    try:
        for path in sorted((workdir / POSIX_SCRIPTS_DIR).glob("*.lua")):
            if path.is_file():
                found[path.name] = path.read_bytes()
    except OSError as exc:
        log.warning("sim_scripts_unreadable", workdir=str(workdir), error=str(exc))
    return found


EMBEDDED_LINK = "udpin:127.0.0.1:0"  # an embedded simulator's own link: a free local UDP port


def embedded_url(server: SimServer) -> str:
    """The URL helixd opens to reach an embedded simulator's own link (once it is bound)."""
    return f"udpout:127.0.0.1:{server.local_ports[0]}"


def start_embedded(
    config: SimConfig, extra_links: tuple[str, ...] = (), judge_pace: bool = False
) -> tuple[SimServer, str]:
    """Run the simulator in-process on a free 127.0.0.1 UDP port (and ``extra_links``, e.g. a
    ground station's ``udpout:127.0.0.1:14550``, routed as ArduPilot routes its ports);
    ``judge_pace``: lower the speed-up the machine does not keep (:mod:`helixd.sim.pace`).

    Returns the server and the URL helixd should open (``udpout:127.0.0.1:PORT``).
    """
    server = SimServer([EMBEDDED_LINK, *extra_links], config, embedded=True, judge_pace=judge_pace)
    server.start()
    return server, embedded_url(server)
