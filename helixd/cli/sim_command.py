"""``helixd sim``: the built-in simulator (:mod:`helixd.sim.server`) in the foreground."""

from __future__ import annotations

import math
import signal
import threading
from pathlib import Path
from typing import Annotated

import structlog
import typer
from pydantic import ValidationError

from helixd.base.clock import now_s
from helixd.base.exitcodes import ExitCode
from helixd.cli.common import SimGroundOpt, SimTerrainOpt, fail, read_sim_ground
from helixd.cli.simulated import read_sim_bathymetry
from helixd.files.media import MediaMapError, read_media_map
from helixd.files.models import ConfigFileError, format_validation_error, load_yaml_model
from helixd.plant.plant_config import Plant
from helixd.sim.faults import FaultError, FaultSpec, parse_fault
from helixd.sim.server import SimServer
from helixd.sim.sim_config import SPEEDUP_MAX, SPEEDUP_MIN, NoiseLevel, SimConfig

log = structlog.get_logger(__name__)

DEFAULT_LINKS = ("tcpin:127.0.0.1:5760", "udpout:127.0.0.1:14550")
STATUS_EVERY_S = 5.0
POLL_S = 0.2


def run_sim(
    links: list[str],
    config: SimConfig,
    faults: list[tuple[FaultSpec, float]],
    duration_s: float | None,
) -> None:
    """Run in the foreground until ``duration_s`` simulated seconds or Ctrl-C."""
    try:
        server = SimServer(links, config)
    except MediaMapError as exc:  # the config's media_file
        raise fail(exc.problems, ExitCode.USAGE) from None
    except ValueError as exc:
        raise fail([f"--listen: {exc}"], ExitCode.USAGE) from None
    try:
        server.start()
    except RuntimeError as exc:
        raise fail([str(exc)], ExitCode.LINK) from None
    stop = threading.Event()

    def on_sigterm(signum: int, frame: object) -> None:
        del signum, frame
        stop.set()

    on_main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, on_sigterm) if on_main else None
    try:
        for spec, at_s in faults:
            server.schedule(spec.name, at_s, **dict(spec.kwargs))
        next_status = now_s() + STATUS_EVERY_S
        while not stop.is_set():
            snap = server.snapshot()
            if duration_s is not None and snap.sim_time_s >= duration_s:
                break
            if now_s() >= next_status:
                next_status += STATUS_EVERY_S
                log.info(
                    "sim_status",
                    sim_time_s=round(snap.sim_time_s, 1),
                    mode=snap.mode,
                    armed=snap.armed,
                    north_m=round(snap.north_m, 2),
                    east_m=round(snap.east_m, 2),
                    yaw_deg=round(math.degrees(snap.yaw_ned_rad), 1),
                    scroll_pwm_us=list(snap.scroll_pwm_us),
                )
            stop.wait(POLL_S)  # foreground idle; the simulator runs on its own thread
        if stop.is_set():
            log.info("sim_terminated")
    except KeyboardInterrupt:
        log.info("sim_interrupted")
    finally:
        if on_main:
            signal.signal(signal.SIGTERM, previous)
        server.stop()


# ``helixd sim``'s own defaults where neither the command line nor the simulator YAML says:
# low pose noise, as ``run --sim`` and ``serve --sim`` (SimConfig's own default, the
# thesis's dual GPS without RTK, moves the reported position 0.6-1.0 m while the rover sits
# in HOLD, which reads as a rover that drifts; ``--noise thesis`` asks for it)
SIM_DEFAULTS: dict[str, object] = {"noise": NoiseLevel.LOW}


def _sim_config(config: Path | None, updates: dict[str, object]) -> SimConfig:
    """The simulator YAML (or the defaults, :data:`SIM_DEFAULTS` over SimConfig's) with the
    command-line options over it; each problem one ``error:`` line named by its option (or
    the file), exit 2."""
    try:
        base = load_yaml_model(config, SimConfig) if config is not None else SimConfig()
    except ConfigFileError as exc:
        for line in exc.problems:
            typer.echo(f"error: {line}", err=True)
        raise typer.Exit(int(ExitCode.USAGE)) from None
    unset = {k: v for k, v in SIM_DEFAULTS.items() if k not in base.model_fields_set}
    try:
        return SimConfig.model_validate({**base.model_dump(), **unset, **updates})
    except ValidationError as exc:
        # one line per problem, named by its command-line option (or the config file)
        for err in exc.errors(include_url=False):
            key = str(err["loc"][0]) if err["loc"] else ""
            sub = ValidationError.from_exception_data(exc.title, [err])  # type: ignore[list-item]
            lines = format_validation_error(config or "helixd sim", sub, SimConfig)
            if key in updates:
                prefix = f"{config or 'helixd sim'}: {key}"
                option = "--" + key.replace("_", "-")
                lines = [option + line.removeprefix(prefix) for line in lines]
            for line in lines:
                typer.echo(f"error: {line}", err=True)
        raise typer.Exit(int(ExitCode.USAGE)) from None


ListenOpt = Annotated[
    list[str] | None,
    typer.Option(
        "--listen",
        "-l",
        metavar="<url>",
        help="MAVLink link: udpin:HOST:PORT, udpout:HOST:PORT or tcpin:HOST:PORT "
        "(repeatable; default tcpin:127.0.0.1:5760 and udpout:127.0.0.1:14550)",
    ),
]
PlantOpt = Annotated[
    Plant | None,
    typer.Option(
        "--plant",
        help="vehicle model: helix (scrolls) or sitl_skid (ArduPilot SITL rover-skid: "
        "outputs 1/3 = left/right motor)",
    ),
]
SpeedupOpt = Annotated[
    float | None,
    typer.Option(
        "--speedup",
        min=SPEEDUP_MIN,
        max=SPEEDUP_MAX,
        help="simulated seconds per wall second (as run --sim-speedup)",
    ),
]
FaultOpt = Annotated[
    list[str] | None,
    typer.Option(
        "--fault",
        metavar="<name@seconds>",
        help="NAME@SECONDS[:key=value,...] in simulated time (repeatable), e.g. "
        "rc_loss@30:duration_s=5",
    ),
]
MediaOpt = Annotated[
    Path | None,
    typer.Option(
        "--media",
        help="media map (GeoJSON or KML: hard, grass, sand, mud, water areas): the world's "
        "media by place, each scroll in the medium under it; --terrain outside",
    ),
]
StateDirOpt = Annotated[
    Path | None,
    typer.Option(
        "--state-dir",
        file_okay=False,
        help="the autopilot's working directory, kept across restarts as SITL's: "
        "scripts/ (an installed helixd-guard) and the parameters set (SCR_ENABLE, "
        "HXG_*); default: a fresh temporary directory each start, so a restarted "
        "simulator forgets an installed guard",
    ),
]


NoiseOpt = Annotated[
    NoiseLevel | None,
    typer.Option(
        "--noise",
        help="pose noise preset: none (exact), low (RTK-like, centimetres), thesis (dual "
        "GPS without RTK: ~1 m, yaw within ±10°); default: the --config file's noise, "
        "else low",
    ),
]
DurationOpt = Annotated[
    float | None, typer.Option("--duration", help="stop after this many simulated s")
]
SeedOpt = Annotated[int | None, typer.Option("--seed", help="noise RNG seed")]
SimConfigOpt = Annotated[
    Path | None, typer.Option("--config", "-c", help="simulator YAML (SimConfig keys)")
]
BathymetryOpt = Annotated[
    Path | None,
    typer.Option(
        "--bathymetry",
        help="the pond's bottom (a bathymetry YAML, docs/survey.md): a down-facing sonar "
        "sends DISTANCE_SENSOR (PITCH_270) and a payload's NAMED_VALUE_FLOAT over water",
    ),
]


def sim_command(
    listen: ListenOpt = None,
    plant: PlantOpt = None,
    terrain: SimTerrainOpt = None,
    noise: NoiseOpt = None,
    speedup: SpeedupOpt = None,
    fault: FaultOpt = None,
    duration: DurationOpt = None,
    seed: SeedOpt = None,
    config: SimConfigOpt = None,
    media: MediaOpt = None,
    state_dir: StateDirOpt = None,
    bathymetry: BathymetryOpt = None,
    ground: SimGroundOpt = None,
) -> None:
    """Run the built-in ArduPilot Rover simulator (QGroundControl/MAVProxy can connect)."""
    given = (
        ("plant", plant),
        ("terrain", terrain),
        ("noise", noise),
        ("speedup", speedup),
        ("seed", seed),
        ("workdir", state_dir),
    )
    updates: dict[str, object] = {key: value for key, value in given if value is not None}
    if media is not None:
        try:
            updates["media"] = read_media_map(media)
        except MediaMapError as exc:
            raise fail([f"--media: {p}" for p in exc.problems], ExitCode.USAGE) from None
        updates["media_file"] = None  # --media replaces the config's
    if bathymetry is not None:
        updates["bathymetry"] = read_sim_bathymetry(bathymetry)
    if ground is not None:
        updates["terrains"] = read_sim_ground(ground)  # replaces the config's terrains
    cfg = _sim_config(config, updates)
    if duration is not None and duration <= 0.0:
        raise fail(["--duration must be > 0"], ExitCode.USAGE)
    try:
        faults = [parse_fault(text) for text in fault or []]
    except FaultError as exc:
        raise fail([str(exc)], ExitCode.USAGE) from None
    run_sim(list(listen or DEFAULT_LINKS), cfg, faults, duration)


def register(app: typer.Typer) -> None:
    """Add ``sim`` to ``app``."""
    app.command("sim")(sim_command)
