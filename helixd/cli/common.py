"""What every CLI command shares: one ``error:`` line per problem, the config or exit 2, the
link URL checked once, and a short session on the autopilot's link."""

from __future__ import annotations

import asyncio
import sys
from collections.abc import Awaitable, Callable
from contextvars import ContextVar
from pathlib import Path
from typing import Annotated, Any, TypeVar

import typer
from typer.core import TyperGroup

from helixd.base.exitcodes import ExitCode
from helixd.base.plan import MotionMode
from helixd.config.link import LinkConfig
from helixd.config.load import config_label, default_config_path, load_config
from helixd.config.root import HelixdConfig
from helixd.files.models import ConfigFileError
from helixd.files.yamlio import MAX_ERROR_LINE_CHARS, clip_line
from helixd.link.connection import Autopilot
from helixd.link.services.ftp_transfer import FtpTransferError
from helixd.link.services.mission_transfer import MissionTransferError
from helixd.mav.url import LinkError, parse_link_url
from helixd.planning.mapfile import OccupancyMap
from helixd.plant.ground import Terrain, TerrainTable, read_ground_file
from helixd.prepare.inputs import InputsRefused
from helixd.prepare.planned import load_occupancy
from helixd.recorder.logging_setup import configure_logging

T = TypeVar("T")

# every command and group: -h as well as --help
CONTEXT_SETTINGS = {"help_option_names": ["-h", "--help"]}
WHOLE_SHORT_HELP_CHARS = 1000  # no command's first sentence is near this long


class WholeHelpGroup(TyperGroup):
    """A command group whose listing shows each command's first sentence whole, wrapped
    (click cuts it at the terminal width with "...")."""

    def format_commands(self, ctx: Any, formatter: Any) -> None:  # click's Context, formatter
        rows = [
            (name, cmd.get_short_help_str(WHOLE_SHORT_HELP_CHARS))
            for name in self.list_commands(ctx)
            if (cmd := self.get_command(ctx, name)) is not None and not cmd.hidden
        ]
        if rows:
            with formatter.section("Commands"):
                formatter.write_dl(rows)


def fail(problems: list[str], code: ExitCode = ExitCode.USAGE) -> typer.Exit:
    """Print each problem as one ``error:`` line; the Exit to raise with ``code``."""
    for line in problems:
        typer.echo(f"error: {clip_line(line, MAX_ERROR_LINE_CHARS)}", err=True)
    return typer.Exit(int(code))


# set by --config's callback for the command being run: whether it said the config already
_CONFIG_SAID: ContextVar[bool] = ContextVar("helixd_config_said", default=False)


def announce_config(path: Path | None) -> None:
    """``config  : FILE`` (or built-in defaults) on stdout, as ``check`` reports it."""
    typer.echo(f"config  : {config_label(path)}")


def resolve_config(ctx: typer.Context, value: Path | None) -> Path | None:
    """``--config``'s callback: the file given, else the default one
    (:func:`helixd.config.load.default_config_path`: ``$HELIXD_CONFIG``, else
    /etc/helixd/helixd.yaml on the rover), else None (built-in defaults). ``run`` says at once
    which one it reads (``check`` prints it in its report; the others when they load it)."""
    path = value if value is not None else default_config_path()
    say = ctx.info_name == "run" and not ctx.resilient_parsing
    if say:
        announce_config(path)
    _CONFIG_SAID.set(say)
    return path


CONFIG_HELP = (
    "helixd.yaml (default: $HELIXD_CONFIG, else /etc/helixd/helixd.yaml where it exists, the "
    "rover's; else the built-in defaults)"
)


def config_option() -> Any:
    """The ``--config/-c`` option every command shares (resolved by :func:`resolve_config`)."""
    return typer.Option("--config", "-c", help=CONFIG_HELP, callback=resolve_config)


# The options several commands share, each defined once.
ConfigOpt = Annotated[Path | None, config_option()]
ConnectOpt = Annotated[  # the link of a command that flies (run, serve)
    str | None,
    typer.Option(
        "--connect",
        help="autopilot link: /dev/ttyACM0[:baud], udpin:HOST:PORT, udpout:HOST:PORT, "
        "tcp:HOST:PORT (default: link.url from the config)",
    ),
]
ObserverConnectOpt = Annotated[  # the link of a command that does not fly (:func:`on_autopilot`)
    str | None,
    typer.Option(
        "--connect",
        help="autopilot link (default: link.url); spoken as link.observer_system (248), never "
        "as the GCS id, and without a HEARTBEAT, so the autopilot's GCS failsafe ignores it",
    ),
]
LogLevelOpt = Annotated[str, typer.Option(help="debug, info, warning or error")]
ModeOpt = Annotated[  # helixd run, check, mission convert
    MotionMode | None,
    typer.Option(
        "--mode",
        help="motion mode of a .plan/.waypoints mission (default: mission.ground_station_mode);"
        " given with a YAML mission it wins over the file's mode: and a warning says so",
    ),
]
SimTerrainOpt = Annotated[  # helixd sim, helixd plant
    Terrain | None, typer.Option("--terrain", help="ground under the rover")
]
SimGroundOpt = Annotated[  # run --sim, helixd sim, helixd plant
    Path | None,
    typer.Option(
        "--sim-ground",
        "--ground",
        help="ground file (YAML keyed by medium: hard, grass, sand, mud, water, each with "
        "roll_efficiency, scroll_efficiency, yaw_efficiency, dig_rate_per_m, pit_escape_per_m, "
        "power_w; whatever is left out keeps the built-in table's value): the simulator's "
        "ground instead of the built-in one",
    ),
]


def read_sim_ground(path: Path) -> TerrainTable:
    """``--sim-ground FILE`` read, or a usage error with one line per problem (each naming the
    file, the medium's field and its range)."""
    try:
        return read_ground_file(path)
    except ConfigFileError as exc:
        raise fail([f"--sim-ground: {line}" for line in exc.problems], ExitCode.USAGE) from None


MapOpt = Annotated[
    Path | None,
    typer.Option(
        "--map",
        help="ROS map_server map (YAML + PGM/PNG, x east / y north from the EKF origin): plan "
        "every leg around it and the planning.keep_out_* shapes (local_ned missions)",
    ),
]


def config_or_exit(config: Path | None) -> HelixdConfig:
    """The config file (``None``: :func:`helixd.config.load.default_config_path`, else the built-in
    defaults), said on stdout, or exit 2 naming every problem."""
    path = config if config is not None else default_config_path()
    try:
        cfg = load_config(path)
    except ConfigFileError as exc:
        raise fail(exc.problems) from None
    if not _CONFIG_SAID.get():
        announce_config(path)
    return cfg


def refused(exc: InputsRefused) -> typer.Exit:
    """An :class:`InputsRefused` as ``error:`` lines and its exit code."""
    return fail(exc.problems, exc.code)


def config_link_map(
    config: Path | None, connect: str | None, map_path: Path | None
) -> tuple[HelixdConfig, str, OccupancyMap | None]:
    """What a command on the link reads first, each refusal exiting as it says: the config
    (:func:`config_or_exit`), the link URL (:func:`check_connect`) and the ``--map``."""
    cfg = config_or_exit(config)
    url = check_connect(connect, cfg)
    try:
        occupancy = load_occupancy(cfg, map_path)
    except InputsRefused as exc:
        raise refused(exc) from None
    return cfg, url, occupancy


def command_group(name: str, help_text: str, **settings: Any) -> typer.Typer:
    """A Typer app or group as all of helixd's: its help when given no arguments, no shell
    completion, no pretty tracebacks; ``settings`` as Typer takes them."""
    return typer.Typer(
        name=name,
        help=help_text,
        no_args_is_help=True,
        add_completion=False,
        pretty_exceptions_enable=False,
        **settings,
    )


def check_connect(connect: str | None, cfg: HelixdConfig) -> str:
    """The link URL to use: ``--connect`` if given (validated; empty is an error), else the
    config's (validated when the config loaded)."""
    if connect is None:
        return cfg.link.url
    try:
        parse_link_url(connect, cfg.link.baud)
    except LinkError as exc:
        raise fail([f"--connect: {exc}"], ExitCode.USAGE) from None
    return connect.strip()


def link_inputs(config: Path | None, connect: str | None) -> tuple[HelixdConfig, LinkConfig]:
    cfg = config_or_exit(config)
    url = check_connect(connect, cfg)
    return cfg, cfg.link.model_copy(update={"url": url})


async def on_autopilot(
    cfg: HelixdConfig, link: LinkConfig, body: Callable[[Autopilot], Awaitable[T]]
) -> T:
    """Connect as an observer (``link.observer_system``, no HEARTBEAT: see
    :meth:`helixd.link.connection.Autopilot.connect`), wait for the autopilot's HEARTBEAT,
    run ``body``, close."""
    ap = await Autopilot.connect(link, cfg.safety, observer=True)
    try:
        await ap.wait_heartbeat(cfg.startup.connect_timeout_s)
        return await body(ap)
    finally:
        await ap.close()


def run_on_link(
    cfg: HelixdConfig, link: LinkConfig, body: Callable[[Autopilot], Awaitable[T]]
) -> T:
    """Run a mission or FTP transfer; link errors exit as ``helixd status`` does (LINK), a
    vehicle's refusal names its MAV_MISSION_RESULT or FTP error (PREFLIGHT: the autopilot would
    not take it), a transfer without answers is a link problem (LINK)."""
    configure_logging(tty=sys.stderr.isatty(), level="warning")
    try:
        return asyncio.run(on_autopilot(cfg, link, body))
    except LinkError as exc:
        raise fail([str(exc)], ExitCode.LINK) from None
    except MissionTransferError as exc:
        code = ExitCode.LINK if exc.result is None else ExitCode.PREFLIGHT
        raise fail([f"{link.url}: {exc}"], code) from None
    except FtpTransferError as exc:
        code = ExitCode.LINK if exc.timed_out else ExitCode.PREFLIGHT
        raise fail([f"{link.url}: {exc}"], code) from None
    except KeyboardInterrupt:
        raise fail(["interrupted"], ExitCode.OPERATOR_STOP) from None


SimBathymetryOpt = Annotated[
    Path | None,
    typer.Option(
        "--sim-bathymetry",
        help="the pond's bottom (a bathymetry YAML, docs/survey.md) under the simulator's "
        "water: a down-facing sonar sends DISTANCE_SENSOR, recorded in payload.csv (with --sim)",
    ),
]
