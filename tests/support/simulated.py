"""Flights on the simulated clock, in this process: the simulator and the daemon's real code
(``helixd run``'s preparation and :func:`helixd.runtime.daemon.run_mission`) share one
:class:`helixd.base.clock.SimulatedClockLoop` and talk MAVLink over real UDP sockets. A flight
takes the CPU time it needs instead of the minutes it lasts, and is the same every time.

For flights a test checks once they ended (exit code, the RESULT line, the log, the run
directory, what the simulator saw). Flights a test steers while they run (signals, faults,
a ground station) use :mod:`tests.support.harness` on the wall clock.
"""

from __future__ import annotations

import asyncio
import io
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import structlog
import yaml

from helixd.base.clock import SimulatedClockLoop, now_s
from helixd.cli.app import flight_options
from helixd.recorder import logging_setup
from helixd.runtime.daemon import RunOutcome, run_mission
from helixd.runtime.prepare import MissionFile, prepare_flight
from helixd.sim.server import EMBEDDED_LINK, SimServer, embedded_url
from helixd.sim.snapshot import SimSnapshot
from tests.support.daemon import deep_merge
from tests.support.harness import BASE_CONFIG, MISSIONS, Trace, sim_config

FLIGHT_LIMIT_S = 1800.0  # simulated seconds: a flight still running then has hung


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

    def run_dir(self) -> Path:
        dirs = sorted(p for p in self.run_root.iterdir() if p.is_dir())
        assert dirs, f"no run directory under {self.run_root}"
        return dirs[-1]

    @property
    def snapshot(self) -> SimSnapshot:
        return self.server.snapshot()


def simulated_flight(
    tmp_path: Path,
    mission: str | Path = "square",
    config: dict[str, Any] | None = None,
    **sim_overrides: Any,
) -> SimulatedFlight:
    """``helixd run --mission MISSION`` with the test config merged over
    :data:`~tests.support.harness.BASE_CONFIG`, against the simulator made of
    ``sim_overrides`` (as :func:`~tests.support.harness.sim_and_daemon` takes them; the
    speed-up is 1: there is no wall clock to outrun)."""
    cfg_path = tmp_path / "helixd.yaml"
    cfg_path.write_text(yaml.safe_dump(deep_merge(BASE_CONFIG, config or {})), encoding="utf-8")
    mission_path = mission if isinstance(mission, Path) else MISSIONS / f"{mission}.yaml"
    got = prepare_flight(MissionFile(mission_path), cfg_path, None)
    server = SimServer([EMBEDDED_LINK], sim_config(**{**sim_overrides, "speedup": 1.0}))
    run_root = tmp_path / "runs"
    console = io.StringIO()
    samples: list[tuple[float, SimSnapshot]] = []
    server.snapshot_listeners.append(lambda snap: samples.append((now_s(), snap)))

    async def fly() -> RunOutcome:
        async with server.running_here():
            url = embedded_url(server)
            opts = flight_options(got.cfg, got.flight, url, run_root, "info", False, tty=False)
            return await asyncio.wait_for(run_mission(opts), FLIGHT_LIMIT_S)

    logging_setup.configure_logging(tty=False, level="info", stream=console)
    try:
        with asyncio.Runner(loop_factory=SimulatedClockLoop) as runner:
            outcome = runner.run(fly())
    finally:
        logging_setup.detach_events_file()
        structlog.reset_defaults()
    lines = [*console.getvalue().splitlines(), *outcome.messages]
    return SimulatedFlight(
        code=int(outcome.exit_code),
        result=outcome.messages[-1] if outcome.messages else "",
        log="\n".join(lines),
        run_root=run_root,
        server=server,
        outcome=outcome,
        trace=Trace(samples),
    )
