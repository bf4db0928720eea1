"""One ``helixd run`` beside the built-in simulator on one simulated clock, in this process: the
benchmarks' default way to fly (``--clock simulated``), so their figures are the rover's, the
same on any machine and under any load, not the machine's.

The daemon's real code (``helixd run``'s preparation and
:func:`helixd.runtime.daemon.run_mission`) and the simulator share one
:class:`helixd.base.clock.SimulatedClockLoop` and talk MAVLink over real UDP sockets, exactly
as ``helixd run --sim --sim-clock simulated`` does; the simulator's truth reaches the caller
through ``on_snapshot``, called on the loop with every snapshot the simulator publishes. With
the simulator's noise seeded, a run is the same flight every time. Run it in a process of its
own (a benchmark's worker): it configures logging for the process.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

import structlog

from helixd.base.clock import SimulatedClockLoop
from helixd.cli.app import flight_options
from helixd.prepare.builder import MissionFile, prepare_flight
from helixd.recorder import logging_setup
from helixd.runtime.daemon import run_mission
from helixd.sim.server import EMBEDDED_LINK, SimServer, embedded_url
from helixd.sim.sim_config import SimConfig
from helixd.sim.snapshot import SimSnapshot

# the simulator runs on after the daemon ended, so its last snapshots are taken
AFTER_S = 1.0
CLOCK_CHOICES = ("simulated", "wall")
CLOCK_HELP = (
    "simulated (default): the daemon and the simulator on one simulated clock, seeded: the "
    "same figures on any machine; wall: the simulator sped up on the wall clock, the daemon a "
    "subprocess (the figures then depend on this machine's speed and load)"
)


def clock_label(clock: str, speedup: float) -> str:
    """How a benchmark's results name the clock its runs flew on."""
    if clock == "simulated":
        return "simulated clock (seeded; the same figures on any machine)"
    return f"WALL CLOCK at speed-up {speedup:g} (figures depend on this machine's speed and load)"


def fly_simulated(
    sim_cfg: SimConfig,
    mission_path: Path,
    cfg_path: Path,
    run_root: Path,
    log_path: Path,
    on_snapshot: Callable[[SimSnapshot], Any],
    limit_s: float,
) -> int | None:
    """``helixd run --mission mission_path --config cfg_path --run-dir run_root`` against a
    simulator made from ``sim_cfg`` (its speed-up ignored: there is no wall to outrun), on
    one simulated clock. The daemon's log goes to ``log_path``; the exit code, or None when
    the flight was still going after ``limit_s`` simulated seconds (it is then cancelled:
    the daemon's own shutdown runs)."""
    server = SimServer([EMBEDDED_LINK], sim_cfg.model_copy(update={"speedup": 1.0}))
    server.snapshot_listeners.append(on_snapshot)
    got = prepare_flight(MissionFile(mission_path), cfg_path, None)

    async def fly() -> int | None:
        async with server.running_here():
            url = embedded_url(server)
            opts = flight_options(got.cfg, got.flight, url, run_root, "info", False, tty=False)
            try:
                outcome = await asyncio.wait_for(run_mission(opts), limit_s)
            except TimeoutError:
                return None
            await asyncio.sleep(AFTER_S)
            return int(outcome.exit_code)

    with log_path.open("w", encoding="utf-8") as log_fh:
        stream: IO[str] = log_fh
        logging_setup.configure_logging(tty=False, level="info", stream=stream)
        try:
            with asyncio.Runner(loop_factory=SimulatedClockLoop) as runner:
                return runner.run(fly())
        finally:
            logging_setup.detach_events_file()
            structlog.reset_defaults()
