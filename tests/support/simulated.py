"""Flights on the simulated clock, in this process: the simulator and the daemon's real code
(``helixd run``'s preparation and :func:`helixd.runtime.daemon.run_mission`) share one
:class:`helixd.base.clock.SimulatedClockLoop` and talk MAVLink over real UDP sockets. A flight
takes the CPU time it needs instead of the minutes it lasts, and is the same every time.

A test checks a flight once it ended (exit code, the RESULT line, the log, the run directory,
what the simulator saw), and may steer it while it runs with ``during``: a coroutine given a
:class:`Steer` (wait for what the simulator shows or the daemon logs, in simulated time; send
the process a signal; inject a fault; move a stick). Flights that need the wall clock (kill -9
and helixd-guard, a second process) use :mod:`tests.support.harness`.
"""

from __future__ import annotations

import asyncio
import io
import os
import signal
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any, cast

import structlog
import yaml

from helixd.base.clock import SimulatedClockLoop, now_s
from helixd.base.exitcodes import ExitCode
from helixd.cli.app import flight_options
from helixd.config.load import load_config
from helixd.prepare.builder import FlightSource, MissionFile, prepare_flight
from helixd.recorder import logging_setup
from helixd.runtime.daemon import RunOutcome, run_mission
from helixd.serve.options import ServeOptions
from helixd.serve.service import serve
from helixd.sim.server import EMBEDDED_LINK, SimServer, embedded_url
from helixd.sim.snapshot import SimSnapshot
from tests.support.daemon import deep_merge
from tests.support.harness import BASE_CONFIG, MISSIONS, Trace, sim_config
from tests.support.kill9 import KILLED_CODE, RESTART_S, DiskImage
from tests.support.loop_mav import LoopMav
from tests.support.serve import CONFIG as SERVE_CONFIG

REAP_S = 30.0  # simulated seconds a killed daemon's cancelled cleanup may take
FLIGHT_LIMIT_S = 1800.0  # simulated seconds: a flight still running then has hung
STEER_AFTER_S = 60.0  # simulated seconds the steering may go on after the flight ended
# the autopilot lives on after helixd exits: what the test reads of it is this much later
AUTOPILOT_AFTER_S = 1.0


def moving(s: SimSnapshot) -> bool:
    """Armed and driving its mission (scrolls commanded, the rover moving)."""
    return s.armed and s.speed_mps > 0.1


class Console(io.TextIOBase):
    """The daemon's console (structlog's stream), kept as lines; waiters woken per line."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self._partial = ""
        self.changed: asyncio.Event | None = None
        self.muted = False  # a killed process's lines: never written

    def write(self, text: str) -> int:
        if self.muted:
            return len(text)
        parts = (self._partial + text).split("\n")
        self._partial = parts.pop()
        if parts:
            self.lines.extend(parts)
            if self.changed is not None:
                self.changed.set()
        return len(text)

    def text(self) -> str:
        return "\n".join([*self.lines, self._partial] if self._partial else self.lines)


class Steer:
    """A test's hands on a flight in progress, on the simulated clock."""

    def __init__(self, server: SimServer, console: Console) -> None:
        self.server = server
        self.console = console
        self.flight: asyncio.Future[Any] | None = None  # the daemon's run, once started
        self.daemon: asyncio.Future[Any] | None = None  # the daemon's own task in it
        self.clients: list[LoopMav] = []
        self.disk: Path | None = None  # what a kill takes back (the service's run root)
        self.killed_at: float | None = None  # when :meth:`kill` killed the daemon
        self._image: DiskImage | None = None
        self._hear_again: Callable[[], None] = lambda: None
        self._snapshot_changed = asyncio.Event()
        console.changed = asyncio.Event()
        self._listener: Callable[[SimSnapshot], None] = lambda _: self._snapshot_changed.set()
        server.snapshot_listeners.append(self._listener)

    @staticmethod
    def now_s() -> float:
        return now_s()

    def snapshot(self) -> SimSnapshot:
        return self.server.snapshot()

    async def until(
        self, predicate: Callable[[SimSnapshot], bool], timeout_s: float
    ) -> SimSnapshot:
        """The first snapshot for which ``predicate`` holds, within ``timeout_s`` simulated."""
        deadline = now_s() + timeout_s
        while not predicate(snap := self.server.snapshot()):
            remaining = deadline - now_s()
            if remaining <= 0:
                name = getattr(predicate, "__name__", "condition")
                raise AssertionError(f"{name} not met within {timeout_s} s; {snap.describe()}")
            self._snapshot_changed.clear()
            try:
                await asyncio.wait_for(self._snapshot_changed.wait(), remaining)
            except TimeoutError:
                continue
        return snap

    def flight_done(self) -> bool:
        return self.flight is not None and self.flight.done()

    async def record_until(
        self, predicate: Callable[[SimSnapshot], bool], timeout_s: float
    ) -> list[SimSnapshot]:
        """Every snapshot published from now until ``predicate`` holds (that one included)."""
        seen: list[SimSnapshot] = []
        self.server.snapshot_listeners.append(seen.append)
        try:
            await self.until(predicate, timeout_s)
        finally:
            self.server.snapshot_listeners.remove(seen.append)
        return seen

    async def exited(self, timeout_s: float) -> float:
        """Until the daemon's run ended (within ``timeout_s`` simulated); the time it did."""
        assert self.flight is not None
        await asyncio.wait_for(asyncio.shield(self.flight), timeout_s)
        return now_s()

    def mark(self) -> int:
        """How many lines were logged so far (for ``line(after=...)``)."""
        return len(self.console.lines)

    async def line(self, needle: str, timeout_s: float, after: int = 0) -> str:
        """The first log line from number ``after`` on containing ``needle``."""
        changed = self.console.changed
        assert changed is not None
        deadline = now_s() + timeout_s
        seen = after
        while True:
            for text in self.console.lines[seen:]:
                if needle in text:
                    return text
            seen = len(self.console.lines)
            remaining = deadline - now_s()
            if remaining <= 0:
                tail = "\n".join(self.console.lines[-40:])
                raise AssertionError(f"no log line with {needle!r} in {timeout_s} s:\n{tail}")
            changed.clear()
            try:
                await asyncio.wait_for(changed.wait(), remaining)
            except TimeoutError:
                continue

    def ground_station(self, link: int, sysid: int, compid: int = 190) -> LoopMav:
        """A MAVLink client on the simulator's ``link`` (1: the first beyond helixd's), closed
        when the flight ends."""
        client = LoopMav(self.server.local_ports[link], sysid, compid)
        self.clients.append(client)
        return client

    def close(self) -> None:
        """Its clients closed and its listener gone: the simulator keeps no steering (and
        through it no daemon) of a start that ended."""
        for client in self.clients:
            client.close()
        if self._listener in self.server.snapshot_listeners:
            self.server.snapshot_listeners.remove(self._listener)

    @staticmethod
    def signal(sig: signal.Signals) -> None:
        """Send this process ``sig``: the daemon's handler on the loop takes it, as a
        ``kill -INT`` of the helixd process would be."""
        os.kill(os.getpid(), sig)

    def kill(self) -> None:
        """kill -9 of the daemon (:mod:`tests.support.kill9`): from now on nothing it does
        reaches the simulator, the console or (once its cancelled cleanup ended) the disk;
        the next start follows after systemd's RestartSec. The steering should return."""
        self.killed_at = now_s()
        self._image = None if self.disk is None else DiskImage.take(self.disk)
        self._hear_again = self.server.cut_peer(0)
        self.console.muted = True
        if self.daemon is not None:
            self.daemon.cancel()

    async def reap(self) -> None:
        """After :meth:`kill`: the cancelled daemon ended (cancelled again while its
        cleanup awaits: a killed process has none), its events file let go and the disk put
        back as it was at the kill; then RestartSec."""
        assert self.daemon is not None and self.flight is not None
        assert self.killed_at is not None
        # its cleanup (the fall-back, the files closed) runs, deaf and mute: let it end, as
        # its sockets and files must be closed (the kernel's part of a kill); one that hangs
        # is cancelled again
        await asyncio.wait({self.daemon}, timeout=REAP_S)
        while not self.daemon.done():
            self.daemon.cancel()
            await asyncio.wait({self.daemon}, timeout=0.05)
        await asyncio.gather(self.flight, return_exceptions=True)
        logging_setup.detach_events_file()
        if self._image is not None:
            self._image.restore()
        self.console.muted = False
        self._hear_again()
        # a killed process is gone: nothing of it kept (a cancelled task's traceback holds
        # every frame of the service: its link, its flight, its records)
        self.daemon = self.flight = None
        await asyncio.sleep(max(0.0, self.killed_at + RESTART_S - now_s()))

    def inject(self, fault: str, **kwargs: object) -> None:
        self.server.inject(fault, **kwargs)

    def schedule(self, fault: str, at_sim_s: float, **kwargs: object) -> None:
        self.server.schedule(fault, at_sim_s, **kwargs)

    def set_rc(self, channel: int, pwm_us: int) -> None:
        self.server.set_rc(channel, pwm_us)


Steering = Callable[[Steer], Awaitable[Any]]


@dataclass(frozen=True)
class SimulatedFlight:
    """How a flight on the simulated clock ended, and what the simulator saw."""

    code: int
    result: str  # the plain ``helixd: RESULT`` line
    log: str  # every log line, then the lines the CLI prints at the end
    run_root: Path
    server: SimServer  # stopped: its snapshot and history stay readable
    outcome: RunOutcome
    trace: Trace  # every snapshot the simulator published: (simulated s, snapshot)
    steered: Any  # what ``during`` returned

    def run_dir(self) -> Path:
        dirs = sorted(p for p in self.run_root.iterdir() if p.is_dir())
        assert dirs, f"no run directory under {self.run_root}"
        return dirs[-1]

    @property
    def snapshot(self) -> SimSnapshot:
        return self.server.snapshot()


async def _fly_and_steer(
    flight: Awaitable[RunOutcome],
    steer: Steer,
    during: Steering | None,
    limit_s: float = FLIGHT_LIMIT_S,
) -> tuple[RunOutcome, Any]:
    """The flight to its end (within ``limit_s`` simulated) and the steering beside it; a
    failed steering ends the flight (cancelled: the daemon's own shutdown runs) and is raised."""
    steer.daemon = asyncio.ensure_future(flight)
    flying = asyncio.ensure_future(asyncio.wait_for(steer.daemon, limit_s))
    steer.flight = flying
    if during is None:
        return await flying, None
    steer_task = asyncio.ensure_future(during(steer))
    try:
        await asyncio.wait({flying, steer_task}, return_when=asyncio.FIRST_COMPLETED)
        if steer.killed_at is not None:  # the steering killed the daemon (kill -9)
            steered = await asyncio.wait_for(steer_task, STEER_AFTER_S)
            await steer.reap()
            return cast(RunOutcome, KILLED_CODE), steered
        if steer_task.done() and steer_task.exception() is not None:
            flying.cancel()
            await asyncio.gather(flying, return_exceptions=True)
            raise steer_task.exception()  # type: ignore[misc]
        outcome = await flying
        return outcome, await asyncio.wait_for(steer_task, STEER_AFTER_S)
    finally:
        steer.close()


Daemon = Callable[[str], Awaitable[Any]]


def _on_simulated_clock(
    server: SimServer,
    runs: Sequence[tuple[Daemon, Steering | None]],
    trace: bool = True,
    console: Console | None = None,
    limit_s: float = FLIGHT_LIMIT_S,
    disk: Path | None = None,
) -> tuple[list[tuple[Any, Any]], Console, list[tuple[float, SimSnapshot]]]:
    """Each of ``runs`` — ``daemon(url)`` steered by its steering — beside ``server`` on one
    simulated clock, one after the other, the simulator running on (a restarted service, a
    resumed run): ([(what the daemon returned, what its steering returned)], the console,
    every snapshot published, if ``trace``). ``disk``: what a steering's kill takes back."""
    console = Console() if console is None else console
    samples: list[tuple[float, SimSnapshot]] = []
    if trace:
        server.snapshot_listeners.append(lambda snap: samples.append((now_s(), snap)))

    async def fly() -> list[tuple[Any, Any]]:
        async with server.running_here():
            url = embedded_url(server)
            results = []
            for daemon, steering in runs:
                steer = Steer(server, console)
                steer.disk = disk
                results.append(await _fly_and_steer(daemon(url), steer, steering, limit_s))
            await asyncio.sleep(AUTOPILOT_AFTER_S)
            return results

    logging_setup.configure_logging(tty=False, level="info", stream=cast(IO[str], console))
    try:
        with asyncio.Runner(loop_factory=SimulatedClockLoop) as runner:
            results = runner.run(fly())
    finally:
        logging_setup.detach_events_file()
        structlog.reset_defaults()
    return results, console, samples


def write_config(tmp_path: Path, *layers: dict[str, Any] | None) -> Path:
    """``tmp_path``/helixd.yaml: the test settings, each layer merged over the one before."""
    merged: dict[str, Any] = {}
    for layer in layers:
        merged = deep_merge(merged, layer or {})
    path = tmp_path / "helixd.yaml"
    path.write_text(yaml.safe_dump(merged), encoding="utf-8")
    return path


Source = str | Path | FlightSource | Callable[[], FlightSource]


def _flight_source(mission: Source) -> FlightSource:
    if callable(mission):
        return mission()
    if isinstance(mission, str):
        return MissionFile(MISSIONS / f"{mission}.yaml")
    return MissionFile(mission) if isinstance(mission, Path) else mission


def simulated_flights(
    tmp_path: Path,
    legs: Sequence[tuple[Source, Steering | None]],
    config: dict[str, Any] | None = None,
    links: int = 1,
    show_plan: bool = False,
    **sim_overrides: Any,
) -> list[SimulatedFlight]:
    """``helixd run`` once per leg — (its mission: a shipped mission's name, a file, a
    :class:`~helixd.prepare.builder.FlightSource` or a function giving one when the leg
    starts, e.g. ``--resume`` of the leg before; its steering) — one after the other against
    one simulator (``links``: helixd's first; ``show_plan``: ``--show-plan``; ``sim_overrides`` as
    :func:`~tests.support.harness.sim_and_daemon` takes them, the speed-up 1: there is no
    wall clock to outrun), with the test config merged over
    :data:`~tests.support.harness.BASE_CONFIG`. Each leg records under ``tmp_path``/runs."""
    cfg_path = write_config(tmp_path, BASE_CONFIG, config)
    server = SimServer([EMBEDDED_LINK] * links, sim_config(**{**sim_overrides, "speedup": 1.0}))
    run_root = tmp_path / "runs"

    notes: list[tuple[str, ...]] = []  # what the CLI prints about each leg's inputs

    def daemon_of(mission: Source) -> Daemon:
        def daemon(url: str) -> Awaitable[RunOutcome]:
            got = prepare_flight(_flight_source(mission), cfg_path, None)
            notes.append(got.notes)
            opts = flight_options(got.cfg, got.flight, url, run_root, "info", show_plan, tty=False)
            return run_mission(opts)

        return daemon

    runs = [(daemon_of(mission), steering) for mission, steering in legs]
    results, console, samples = _on_simulated_clock(server, runs)
    return [
        SimulatedFlight(
            code=int(outcome.exit_code),
            result=outcome.messages[-1] if outcome.messages else "",
            log="\n".join([*leg_notes, console.text(), *outcome.messages]),
            run_root=run_root,
            server=server,
            outcome=outcome,
            trace=Trace(samples),
            steered=steered,
        )
        for (outcome, steered), leg_notes in zip(results, notes, strict=True)
    ]


def simulated_flight(
    tmp_path: Path,
    mission: Source = "square",
    config: dict[str, Any] | None = None,
    during: Steering | None = None,
    links: int = 1,
    show_plan: bool = False,
    **sim_overrides: Any,
) -> SimulatedFlight:
    """``helixd run --mission MISSION`` on the simulated clock, steered by ``during`` if
    given (:func:`simulated_flights` with one leg)."""
    legs = [(mission, during)]
    (flown,) = simulated_flights(tmp_path, legs, config, links, show_plan, **sim_overrides)
    return flown


@dataclass(frozen=True)
class SimulatedService:
    """How ``helixd serve`` on the simulated clock ended (each start of it: ``codes``,
    ``steered``), and what the simulator saw."""

    codes: list[int]
    log: str
    run_root: Path
    server: SimServer
    steered: list[Any]

    @property
    def code(self) -> int:
        return self.codes[-1]


def simulated_serve(
    tmp_path: Path,
    during: Steering | Sequence[Steering],
    config: dict[str, Any] | None = None,
    links: int = 2,
    limit_s: float = FLIGHT_LIMIT_S,
    **sim_overrides: Any,
) -> SimulatedService:
    """``helixd serve`` with ``config`` merged over the serve tests' settings
    (:data:`tests.support.serve.CONFIG` over BASE_CONFIG), beside the simulator (``links``:
    helixd's first, a ground station's next), steered by ``during`` — which ends the service
    (SIGTERM) when it is done; a list: the service started again for each, the simulator
    running on. Each start is ended as hung after ``limit_s`` simulated seconds. A steering
    may kill the service (:meth:`Steer.kill`: its code :data:`~tests.support.kill9.KILLED_CODE`,
    the run root as it was at the kill, the next start after RestartSec)."""
    cfg_path = write_config(tmp_path, BASE_CONFIG, SERVE_CONFIG, config)
    cfg = load_config(cfg_path)
    server = SimServer([EMBEDDED_LINK] * links, sim_config(**{**sim_overrides, "speedup": 1.0}))
    run_root = tmp_path / "runs"

    def daemon(url: str) -> Awaitable[ExitCode]:
        served = cfg.model_copy(update={"link": cfg.link.model_copy(update={"url": url})})
        opts = ServeOptions(
            cfg=served,
            config_path=cfg_path,
            run_root=run_root,
            mission_file=cfg.serve.mission_file,
        )
        return serve(opts)

    steerings = list(during) if isinstance(during, Sequence) else [during]
    runs = [(daemon, steering) for steering in steerings]
    console = Console()
    try:
        results, _, _ = _on_simulated_clock(
            server, runs, trace=False, console=console, limit_s=limit_s, disk=run_root
        )
    finally:  # the service's log beside the test's files, also for a failure
        (tmp_path / "serve.log").write_text(console.text(), encoding="utf-8")
    codes = [int(code) for code, _ in results]
    return SimulatedService(codes, console.text(), run_root, server, [s for _, s in results])
