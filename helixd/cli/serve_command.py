"""``helixd serve``: the all-day service (:mod:`helixd.serve.service`) on the command line."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from helixd.base.exitcodes import ExitCode
from helixd.base.plan import MotionMode
from helixd.cli.common import (
    ConfigOpt,
    ConnectOpt,
    LogLevelOpt,
    MapOpt,
    SimBathymetryOpt,
    config_link_map,
    fail,
)
from helixd.cli.simulated import (
    SimChoice,
    SimMediaOpt,
    SpeedupOpt,
    TerrainOpt,
    sim_world,
    simulator,
    with_sim,
    with_sim_files,
)
from helixd.mav.url import LinkError, parse_link_url
from helixd.plant.ground import Terrain
from helixd.plant.plant_config import Plant
from helixd.recorder.logging_setup import configure_logging
from helixd.runtime import eventloop
from helixd.serve.options import ServeOptions
from helixd.serve.service import serve
from helixd.sim.sim_config import NoiseLevel

__all__ = ["register"]


def serve_command(
    config: ConfigOpt = None,
    connect: ConnectOpt = None,
    sim: Annotated[
        bool, typer.Option("--sim", help="serve the built-in simulator, started in-process")
    ] = False,
    sim_speedup: SpeedupOpt = 1.0,
    sim_terrain: TerrainOpt = Terrain.HARD,
    sim_gcs: Annotated[
        str | None,
        with_sim(
            "also give a ground station a link to the simulator, e.g. udpout:127.0.0.1:14550 "
            "for QGroundControl on this machine"
        ),
    ] = None,
    run_dir: Annotated[
        Path | None,
        typer.Option("--run-dir", help="root for run directories (default: recorder.run_root)"),
    ] = None,
    mode: Annotated[
        MotionMode | None,
        typer.Option(
            "--mode",
            help="motion mode for the autopilot's missions (default: mission.ground_station_mode)",
        ),
    ] = None,
    mission: Annotated[
        Path | None,
        typer.Option(
            "--mission",
            "-m",
            help="for crews without a ground station: fly this mission file instead of the "
            "autopilot's (default: serve.mission_file, else the autopilot's mission)",
        ),
    ] = None,
    map_path: MapOpt = None,
    log_level: LogLevelOpt = "info",
    sim_bathymetry: SimBathymetryOpt = None,
    sim_media: SimMediaOpt = None,
) -> None:
    """Run all day: fly the autopilot's mission when an operator starts it (start switch,
    MISSION_START, or the autopilot armed in AUTO: a ground station's Start Mission), pause
    and continue on the switch, DO_PAUSE_CONTINUE or HOLD then AUTO again; never moves on its
    own. Stops on SIGINT/SIGTERM (a flight in progress falls back to HOLD first)."""
    choice = _sim_choice(sim, connect, sim_speedup, sim_terrain, sim_gcs)
    choice = with_sim_files(choice, sim_media, bathymetry=sim_bathymetry)
    cfg, url, occupancy = config_link_map(config, connect, map_path)
    configure_logging(tty=sys.stderr.isatty(), level=log_level)
    with simulator(choice, lambda: sim_world(cfg, occupancy), url, cfg) as link_url:
        served = cfg.model_copy(update={"link": cfg.link.model_copy(update={"url": link_url})})
        opts = ServeOptions(
            cfg=served,
            config_path=config,
            run_root=run_dir or cfg.recorder.run_root,
            mode=mode,
            occupancy=occupancy,
            mission_file=mission or cfg.serve.mission_file,
        )
        code = eventloop.run(serve(opts), cfg.link.event_loop)
    raise typer.Exit(int(code))


def _sim_choice(
    sim: bool, connect: str | None, speedup: float, terrain: Terrain, sim_gcs: str | None
) -> SimChoice | None:
    """The simulator to serve (``--sim``), with a ground station's link (``--sim-gcs``)."""
    if sim and connect is not None:
        raise fail(["--sim and --connect exclude each other"], ExitCode.USAGE)
    if sim_gcs is not None:
        if not sim:
            raise fail(["--sim-gcs needs --sim"], ExitCode.USAGE)
        try:
            parse_link_url(sim_gcs, 115200)
        except LinkError as exc:
            raise fail([f"--sim-gcs: {exc}"], ExitCode.USAGE) from None
    if not sim:
        return None
    links = () if sim_gcs is None else (sim_gcs,)
    return SimChoice(speedup, terrain, Plant.HELIX, NoiseLevel.LOW, extra_links=links)


def register(app: typer.Typer) -> None:
    app.command(name="serve")(serve_command)
