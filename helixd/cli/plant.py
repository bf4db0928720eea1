"""``helixd plant``: the Helix plant as ArduPilot SITL's physics (``ardurover --model JSON``).

The same physics ``helixd sim`` flies (eq. 1, motor lag, terrain traction and pits; a media
map's ground by place) answers real ArduPilot's servo outputs, so ArduPilot's own EKF3,
outputs and modes meet the Helix's four scrolls (helixd.plant.json_physics). Start it first,
then SITL::

    helixd plant --terrain mud &
    ardurover --model JSON --defaults config/ardupilot/helix.parm,… -I0
"""

from __future__ import annotations

import signal
import socket
import threading
from pathlib import Path
from typing import Annotated

import typer

from helixd.base.exitcodes import ExitCode
from helixd.cli.common import SimGroundOpt, SimTerrainOpt, fail, read_sim_ground
from helixd.cli.simulated import read_sim_bathymetry
from helixd.files.media import MediaMapError, read_media_map
from helixd.files.models import ConfigFileError, load_yaml_model
from helixd.mission.placed import parse_latlon
from helixd.plant.ground import Terrain
from helixd.plant.json_server import PlantStats, open_socket, serve_plant
from helixd.sim.sim_config import SimConfig

SITL_JSON_PORT = 9002  # SIM_JSON's default; ArduPilot adds 10 per -I instance
PORT_STRIDE = 10


def parse_home(text: str) -> tuple[float, float]:
    """SITL's ``--home LAT,LON[,ALT,YAW]`` → (lat, lon) in degrees; ValueError naming why."""
    parts = text.split(",")
    if len(parts) not in (2, 4):
        raise ValueError(f"--home {text!r}: expected LAT,LON or LAT,LON,ALT,YAW (SITL's)")
    try:
        return parse_latlon(",".join(parts[:2]))
    except ValueError as exc:  # the reason, for the whole --home value
        raise ValueError(f"--home {text!r}: {str(exc).split(': ', 1)[-1]}") from None


def plant_config(
    config: Path | None,
    terrain: Terrain | None,
    media: Path | None,
    home: str | None,
    ground: Path | None = None,
) -> SimConfig:
    """The simulator YAML with the command line's ground, map, home and ground file; exit 2
    naming why."""
    try:
        cfg = load_yaml_model(config, SimConfig) if config is not None else SimConfig()
    except ConfigFileError as exc:
        raise fail(exc.problems) from None
    if terrain is not None:
        cfg = cfg.model_copy(update={"terrain": terrain})
    if home is not None:
        try:
            lat, lon = parse_home(home)
        except ValueError as exc:
            raise fail([str(exc)]) from None
        cfg = cfg.model_copy(update={"origin_lat_deg": lat, "origin_lon_deg": lon})
    if media is not None:
        try:
            media_map = read_media_map(media)
        except MediaMapError as exc:
            raise fail(exc.problems) from None
        if media_map.needs_origin and home is None:
            raise fail([f"--media {media}: a lat/lon map needs --home LAT,LON (SITL's --home)"])
        cfg = cfg.model_copy(update={"media": media_map})
    if ground is not None:
        cfg = cfg.model_copy(update={"terrains": read_sim_ground(ground)})
    return cfg


def plant_command(
    instance: Annotated[
        int,
        typer.Option(
            "--instance",
            "-I",
            min=0,
            max=99,
            help="the SITL instance (ardurover -I N) to serve: UDP port 9002 + 10·N",
        ),
    ] = 0,
    port: Annotated[
        int | None,
        typer.Option(
            "--port", min=1, max=65535, help="UDP port instead (ardurover --sim-port-out)"
        ),
    ] = None,
    host: Annotated[str, typer.Option("--host", help="address to listen on")] = "127.0.0.1",
    terrain: SimTerrainOpt = None,
    config: Annotated[
        Path | None,
        typer.Option(
            "--config",
            "-c",
            help="simulator YAML (SimConfig keys: vehicle, terrains, scroll_output_channels, "
            "scroll_reversed, motor_*; the autopilot's own keys do not apply)",
        ),
    ] = None,
    media: Annotated[
        Path | None,
        typer.Option(
            "--media",
            help="media map (GeoJSON/KML: hard, grass, sand, mud, water by place): each "
            "scroll meets the medium under it; a lat/lon map needs --home",
        ),
    ] = None,
    home: Annotated[
        str | None,
        typer.Option("--home", help="SITL's --home LAT,LON[,ALT,YAW]: where a lat/lon map is"),
    ] = None,
    truth_csv: Annotated[
        Path | None,
        typer.Option("--truth-csv", help="write the true pose here, 10 rows per simulated s"),
    ] = None,
    bathymetry: Annotated[
        Path | None,
        typer.Option(
            "--bathymetry",
            help="the pond's bottom (bathymetry YAML, docs/survey.md): its depth under the "
            "rover goes to SITL's rangefinder 1 (JSON rng_1; RNGFND1_TYPE 100); needs --home",
        ),
    ] = None,
    ground: SimGroundOpt = None,
) -> None:
    """Serve ArduPilot SITL's JSON physics interface with the Helix plant (Ctrl-C stops)."""
    cfg = plant_config(config, terrain, media, home, ground)
    if bathymetry is not None:
        if home is None:
            raise fail([f"--bathymetry {bathymetry}: needs --home LAT,LON (SITL's --home)"])
        cfg = cfg.model_copy(update={"bathymetry": read_sim_bathymetry(bathymetry)})
    udp_port = port if port is not None else SITL_JSON_PORT + PORT_STRIDE * instance
    try:
        sock = open_socket(host, udp_port)
    except OSError as exc:
        raise fail([f"cannot listen on udp {host}:{udp_port}: {exc}"], ExitCode.LINK) from None
    typer.echo(
        f"helixd plant: Helix physics on udp {host}:{udp_port}, terrain {cfg.terrain.value}"
        f"{f', media {media}' if media is not None else ''}; "
        f"start ardurover --model JSON (-I {instance})"
    )
    stats = _serve_until_stopped(cfg, sock, truth_csv)
    if stats is not None:
        typer.echo(
            f"helixd plant: {stats.frames} frames, {stats.sim_time_s:.1f} s simulated in "
            f"{stats.wall_time_s:.1f} s ({stats.rate_hz:.0f} frames/s), "
            f"{stats.bad_datagrams} bad datagrams, {stats.restarts} restarts"
        )


def _serve_until_stopped(
    cfg: SimConfig, sock: socket.socket, truth_csv: Path | None
) -> PlantStats | None:
    """Serve until SIGTERM or Ctrl-C (None: interrupted)."""
    stop = threading.Event()

    def on_signal(signum: int, frame: object) -> None:
        del signum, frame
        stop.set()

    previous = signal.signal(signal.SIGTERM, on_signal)
    try:
        return serve_plant(cfg, sock, stop, truth_csv)
    except KeyboardInterrupt:
        return None
    finally:
        signal.signal(signal.SIGTERM, previous)


def register(app: typer.Typer) -> None:
    """Add ``plant`` to ``app``."""
    app.command("plant")(plant_command)
