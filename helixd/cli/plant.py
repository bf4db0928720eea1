"""``helixd plant``: the Helix plant as ArduPilot SITL's physics (``ardurover --model JSON``).

The same physics ``helixd sim`` flies (eq. 1, motor lag, terrain traction and pits) answers
real ArduPilot's servo outputs, so ArduPilot's own EKF3, outputs and modes meet the Helix's
four scrolls (helixd.sim.json_physics). Start it first, then SITL::

    helixd plant --terrain mud &
    ardurover --model JSON --defaults config/ardupilot/helix.parm,… -I0
"""

from __future__ import annotations

import signal
import threading
from pathlib import Path
from typing import Annotated

import typer

from helixd.base.exitcodes import ExitCode
from helixd.cli.common import fail
from helixd.files.models import ConfigFileError, load_yaml_model
from helixd.sim.json_server import open_socket, serve_plant
from helixd.sim.sim_config import SimConfig, Terrain

SITL_JSON_PORT = 9002  # SIM_JSON's default; ArduPilot adds 10 per -I instance
PORT_STRIDE = 10


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
    terrain: Annotated[
        Terrain | None, typer.Option("--terrain", help="ground under the rover")
    ] = None,
    config: Annotated[
        Path | None,
        typer.Option(
            "--config",
            "-c",
            help="simulator YAML (SimConfig keys: vehicle, terrains, scroll_output_channels, "
            "scroll_reversed, motor_*; the autopilot's own keys do not apply)",
        ),
    ] = None,
    truth_csv: Annotated[
        Path | None,
        typer.Option("--truth-csv", help="write the true pose here, 10 rows per simulated s"),
    ] = None,
) -> None:
    """Serve ArduPilot SITL's JSON physics interface with the Helix plant (Ctrl-C stops)."""
    try:
        cfg = load_yaml_model(config, SimConfig) if config is not None else SimConfig()
    except ConfigFileError as exc:
        raise fail(exc.problems) from None
    if terrain is not None:
        cfg = cfg.model_copy(update={"terrain": terrain})
    udp_port = port if port is not None else SITL_JSON_PORT + PORT_STRIDE * instance
    try:
        sock = open_socket(host, udp_port)
    except OSError as exc:
        raise fail([f"cannot listen on udp {host}:{udp_port}: {exc}"], ExitCode.LINK) from None
    stop = threading.Event()

    def on_signal(signum: int, frame: object) -> None:
        del signum, frame
        stop.set()

    previous = signal.signal(signal.SIGTERM, on_signal)
    typer.echo(
        f"helixd plant: Helix physics on udp {host}:{udp_port}, terrain {cfg.terrain.value}; "
        f"start ardurover --model JSON (-I {instance})"
    )
    try:
        stats = serve_plant(cfg, sock, stop, truth_csv)
    except KeyboardInterrupt:
        stats = None
    finally:
        signal.signal(signal.SIGTERM, previous)
    if stats is not None:
        typer.echo(
            f"helixd plant: {stats.frames} frames, {stats.sim_time_s:.1f} s simulated in "
            f"{stats.wall_time_s:.1f} s ({stats.rate_hz:.0f} frames/s), "
            f"{stats.bad_datagrams} bad datagrams, {stats.restarts} restarts"
        )


def register(app: typer.Typer) -> None:
    """Add ``plant`` to ``app``."""
    app.command("plant")(plant_command)
