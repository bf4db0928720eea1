"""Command-line interface: ``helixd run | check | serve | status | sim | plant | plot | replay
| export | mission | autopilot | version``.

Errors the operator can fix (bad file, bad URL, refused preflight) are printed as one clear
message per problem and a non-zero exit code — never a traceback.
"""

from __future__ import annotations

import asyncio
import re
import shutil
import sys
from collections.abc import Mapping
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Annotated

import typer
from typer.exceptions import TyperException

from helixd import __version__
from helixd.base.exitcodes import ExitCode
from helixd.base.plan import MissionFrameKind, MotionMode
from helixd.cli import autopilot_check as cli_autopilot_check
from helixd.cli import autopilot_setup as cli_autopilot_setup
from helixd.cli import ground as cli_ground
from helixd.cli import guard as cli_guard
from helixd.cli import mission as cli_mission
from helixd.cli import plant as cli_plant
from helixd.cli import runs as cli_runs
from helixd.cli import serve_command as cli_serve
from helixd.cli import sim_command as cli_sim
from helixd.cli import survey_map as cli_survey_map
from helixd.cli.autopilot import fetch_autopilot_mission, wants_autopilot
from helixd.cli.common import (
    CONTEXT_SETTINGS,
    ConfigOpt,
    ConnectOpt,
    LogLevelOpt,
    MapOpt,
    ModeOpt,
    ObserverConnectOpt,
    SimBathymetryOpt,
    SimGroundOpt,
    WholeHelpGroup,
    check_connect,
    command_group,
    config_link_map,
    config_or_exit,
    fail,
    refused,
)
from helixd.cli.simulated import (
    SimChoice,
    SimMediaOpt,
    SpeedupOpt,
    TerrainOpt,
    beside_simulator,
    sim_world,
    simulator,
    simulator_config,
    with_sim,
    with_sim_files,
)
from helixd.commands.status import HeldLog, log_lines, read_status
from helixd.config.root import HelixdConfig
from helixd.files.yamlio import clip_line
from helixd.mav.url import LinkError
from helixd.mission.describe import DEFAULT_WIDTH
from helixd.mission.expand import ExpandOptions
from helixd.mission.locate import SEARCH_DIRS, available_missions
from helixd.planning.mapfile import OccupancyMap
from helixd.plant.ground import Terrain
from helixd.plant.plant_config import Plant
from helixd.prepare.builder import (
    AutopilotMission,
    FlightSource,
    MissionFile,
    Prepared,
    Resume,
    prepare_flight,
)
from helixd.prepare.inputs import InputsRefused
from helixd.prepare.plan_report import check_lines, record_space_warning
from helixd.prepare.planned import Flight, route_lines
from helixd.recorder.logging_setup import configure_logging
from helixd.runtime import eventloop
from helixd.runtime.daemon import RunOptions, run_mission
from helixd.sim.sim_config import NoiseLevel, SimClock, SimConfig

app = command_group(
    "helixd",
    "Fly the Helix-25 screw-propelled rover through waypoint missions over MAVLink.",
    # plain help (click's): wrapped at any width, never cut with "…", flags without "<bool>"
    rich_markup_mode=None,
    context_settings=CONTEXT_SETTINGS,
    cls=WholeHelpGroup,
)


def _print_version(value: bool) -> None:
    if value:
        typer.echo(f"helixd {__version__}")
        raise typer.Exit(0)


@app.callback()
def main_options(
    version: Annotated[
        bool,
        typer.Option(
            "--version",
            "-V",
            callback=_print_version,
            is_eager=True,
            help="print the helixd version and exit",
        ),
    ] = False,
) -> None:
    """Fly the Helix-25 screw-propelled rover through waypoint missions over MAVLink."""


MissionOpt = Annotated[
    Path,
    typer.Option(
        "--mission",
        "-m",
        help="mission YAML file; a bare name such as square.yaml is also looked up in "
        "config/missions/ and /etc/helixd/missions/; `run --mission autopilot` flies the "
        "mission the autopilot holds",
    ),
]
CheckMissionOpt = Annotated[
    Path | None,
    typer.Option(
        "--mission",
        "-m",
        help="mission YAML file; a bare name such as square.yaml is also looked up in "
        "config/missions/ and /etc/helixd/missions/",
    ),
]
SkipOpt = Annotated[
    bool,
    typer.Option(
        "--skip-unsupported",
        help="pass over mission items helixd cannot fly (listed, logged) instead of refusing "
        "the mission, as ArduPilot Rover passes over what it cannot do",
    ),
]
StrictOpt = Annotated[
    bool,
    typer.Option(
        "--strict",
        help="refuse the items ArduPilot Rover itself skips or ignores (NAV_TAKEOFF, "
        "NAV_LAND, altitude-only items, mount control and the like) instead of skipping them",
    ),
]
FenceOpt = Annotated[
    Path | None,
    typer.Option(
        "--fence",
        help="fence file: a Mission Planner fence (QGC WPL 110, commands 5000-5004) or a "
        ".plan's geoFence; inclusion shapes keep the rover in, exclusions are planned around",
    ),
]


PLOT_NEEDS_ROUTE = (
    "--plot draws a route planned around obstacles (--map, keep-out areas, a fence's "
    "exclusions) or a media map's stretches, and this mission has neither; `helixd plot "
    "RUN_DIR` draws a flown run"
)


@app.command()
def version() -> None:
    """Print the helixd version."""
    typer.echo(f"helixd {__version__}")


@app.command()
def check(
    config: ConfigOpt = None,
    mission: CheckMissionOpt = None,
    map_path: MapOpt = None,
    plot: Annotated[
        Path | None,
        typer.Option("--plot", help="with planning: draw map, inflation and path to this PNG"),
    ] = None,
    mode: ModeOpt = None,
    skip_unsupported: SkipOpt = False,
    strict: StrictOpt = False,
    fence: FenceOpt = None,
) -> None:
    """Validate the config and a mission (as `run` would), and print the resolved plan."""
    if mission is None:
        known = available_missions()
        listed = ", ".join(known) if known else "none in " + ", ".join(map(str, SEARCH_DIRS))
        raise fail([f"check needs --mission FILE; available: {listed}"], ExitCode.USAGE)
    source = MissionFile(mission, mode, fence, ExpandOptions(strict, skip_unsupported))
    got = prepared_or_exit(source, config, map_path)
    label = str(config or "(built-in defaults)")
    flight = got.flight
    route = flight.route
    width = shutil.get_terminal_size((DEFAULT_WIDTH, 24)).columns  # COLUMNS, else the tty's
    lines = check_lines(
        got.cfg, got.mission, got.path, label, flight.mission, route, flight.options, width,
        got.media,
    )  # fmt: skip
    typer.echo("\n".join(lines))
    low = record_space_warning(got.cfg, flight.mission, route, got.path)
    if low is not None:
        typer.echo(f"warning: {low}", err=True)
    if plot is not None:
        _check_plot(got, plot)


def _check_plot(got: Prepared, plot: Path) -> None:
    """``check --plot``: the route planned around obstacles, the media map's areas under it;
    without a route, a media map's areas and the plan's stretches by mode; else say why not."""
    # deferred, as `helixd plot`'s: matplotlib (0.2 s) only when a plot is asked for
    from helixd.prepare.media_figure import checked_media

    flight = got.flight
    media = None
    if got.media is not None:
        media = checked_media(got.cfg, got.mission, flight.mission, got.media, flight.options)
    if flight.route is None and (media is None or media.placed is None):
        why = (
            PLOT_NEEDS_ROUTE if media is None else f"{PLOT_NEEDS_ROUTE}; the media map: {media.why}"
        )
        typer.echo(f"plot    : {plot} not written: {why}")  # said, not silently skipped
        return
    from helixd.recorder.plan_plots import render_media_plan, render_route  # start-up: matplotlib

    name = got.mission.name
    try:
        if flight.route is not None:
            placed = None if media is None else media.placed
            out = render_route(flight.route, plot, title=name, media=placed)
        else:
            assert media is not None and media.placed is not None and media.plan is not None
            start = media.plan.plan.assumed_start_xy_m()
            global_ = got.mission.frame is MissionFrameKind.GLOBAL
            where = " of waypoint 1" if global_ else ""
            names = (f"east{where} (m)", f"north{where} (m)")
            out = render_media_plan(
                media.placed, media.plan, plot, start_xy_m=start, axis_names=names, title=name
            )
    except OSError as exc:
        raise fail([f"--plot: cannot write {plot}: {exc}"], ExitCode.USAGE) from None
    typer.echo(f"plot    : {out}")


SimOpt = Annotated[
    bool, typer.Option("--sim", help="fly against the built-in simulator, started in-process")
]


PlantOpt = Annotated[
    Plant,
    with_sim(
        "simulator vehicle model; sitl_skid needs the SITL channel mapping in --config "
        "(tests/sitl/README.md)"
    ),
]
NoiseOpt = Annotated[NoiseLevel, with_sim("simulator pose noise")]
SimClockOpt = Annotated[
    SimClock,
    with_sim(
        "wall: the simulator runs on the wall clock, sped up by --sim-speedup; simulated: "
        "the simulator and helixd share one simulated clock that skips every wait (a flight "
        "takes the CPU time it needs; with --sim-seed the same flight every time)"
    ),
]
SimSeedOpt = Annotated[int | None, with_sim("the simulator's noise seed (default: new)", 0)]
RunDirOpt = Annotated[
    Path | None,
    typer.Option(
        "--run-dir",
        help="root for run directories (default: recorder.run_root; with --resume, the "
        "interrupted run's)",
    ),
]
ShowPlanOpt = Annotated[
    bool,
    typer.Option(
        "--show-plan",
        help="upload the resolved plan as the autopilot's mission so the ground station "
        "draws the path (helixd never switches to AUTO, so ArduPilot never flies it)",
    ),
]
ResumeOpt = Annotated[
    Path | None,
    typer.Option(
        "--resume",
        help="continue the mission of this run directory from its first waypoint not "
        "reached (refused if the mission or config changed, or the run completed)",
    ),
]


@app.command()
def run(
    ctx: typer.Context,
    mission: MissionOpt = Path("mission.yaml"),
    config: ConfigOpt = None,
    connect: ConnectOpt = None,
    sim: SimOpt = False,
    sim_speedup: SpeedupOpt = 1.0,
    sim_terrain: TerrainOpt = Terrain.HARD,
    sim_plant: PlantOpt = Plant.HELIX,
    sim_noise: NoiseOpt = NoiseLevel.LOW,
    run_dir: RunDirOpt = None,
    log_level: LogLevelOpt = "info",
    map_path: MapOpt = None,
    mode: ModeOpt = None,
    skip_unsupported: SkipOpt = False,
    strict: StrictOpt = False,
    fence: FenceOpt = None,
    show_plan: ShowPlanOpt = False,
    resume: ResumeOpt = None,
    sim_media: SimMediaOpt = None,
    sim_clock: SimClockOpt = SimClock.WALL,
    sim_seed: SimSeedOpt = None,
    sim_bathymetry: SimBathymetryOpt = None,
    sim_ground: SimGroundOpt = None,
) -> None:
    """Fly a mission: connect, preflight, arm, fly, and always stop + release + HOLD.

    --mission autopilot flies the mission the autopilot holds (downloaded over MAVLink);
    --resume RUN_DIR continues a recorded run from its first waypoint not reached."""
    if sim and connect is not None:
        raise fail(["--sim and --connect exclude each other"], ExitCode.USAGE)
    choice = (
        SimChoice(sim_speedup, sim_terrain, sim_plant, sim_noise, clock=sim_clock, seed=sim_seed)
        if sim
        else None
    )
    choice = with_sim_files(choice, sim_media, sim_ground, sim_bathymetry)
    options = ExpandOptions(strict, skip_unsupported)
    if wants_autopilot(mission) and resume is None:
        if choice is not None and choice.clock is SimClock.SIMULATED:
            raise fail(
                ["--sim-clock simulated flies mission files; --mission autopilot needs the wall"],
                ExitCode.USAGE,
            )
        _run_autopilot_mission(
            config, connect, choice, run_dir, log_level, map_path, mode, options, show_plan, fence
        )
        return  # not reached: it exits with the run's code
    source: FlightSource = MissionFile(mission, mode, fence, options)
    if resume is not None:
        not_allowed = {
            "--mode": mode,
            "--map": map_path,
            "--skip-unsupported": skip_unsupported,
            "--strict": strict,
            "--fence": fence,
        }
        source = _resume_source(ctx, mission, resume, not_allowed)
        run_dir = run_dir or resume.resolve().parent  # beside the interrupted run
    # planned around obstacles; refusals before a simulator starts
    got = prepared_or_exit(source, config, map_path)
    cfg = got.cfg
    url = check_connect(connect, cfg)
    echo_flight(got.flight)
    if choice is not None:  # --resume: the rover is where the run left it
        choice = replace(choice, start_ned=got.last_pose_ned)
    world = partial(sim_world, cfg, got.occupancy, got.fence)
    if choice is not None and choice.clock is SimClock.SIMULATED:
        sim_cfg = simulator_config(choice, world, cfg)
        _fly(got, url, run_dir, log_level, show_plan, beside=sim_cfg)
    with simulator(choice, world, url, cfg) as url:
        _fly(got, url, run_dir, log_level, show_plan)


def _run_autopilot_mission(
    config: Path | None,
    connect: str | None,
    sim_choice: SimChoice | None,
    run_dir: Path | None,
    log_level: str,
    map_path: Path | None,
    mode: MotionMode | None,
    options: ExpandOptions,
    show_plan: bool,
    fence: Path | None,
) -> None:
    """``run --mission autopilot``: download and convert the autopilot's mission (its stored
    fence with it), then check and fly it as any other (see :mod:`helixd.cli.autopilot`).
    Refusals of the mission exit 3."""
    cfg, url, occupancy = config_link_map(config, connect, map_path)
    with simulator(sim_choice, lambda: sim_world(cfg, occupancy), url, cfg) as url:
        got = fetch_autopilot_mission(cfg, url, mode, fence)
        prepared = prepared_or_exit(AutopilotMission(got, cfg, options), config, occupancy)
        echo_flight(prepared.flight)
        _fly(prepared, url, run_dir, log_level, show_plan)


def flight_options(
    cfg: HelixdConfig,
    flight: Flight,
    url: str,
    run_dir: Path | None,
    log_level: str,
    show_plan: bool,
    tty: bool,
) -> RunOptions:
    """What the daemon flies for ``helixd run``: the prepared ``flight`` over ``url``."""
    return RunOptions(
        cfg=cfg.model_copy(update={"link": cfg.link.model_copy(update={"url": url})}),
        mission=flight.mission,
        mission_yaml=flight.mission_yaml,
        connect_url=url,
        run_root=run_dir or cfg.recorder.run_root,
        tty=tty,
        plain_progress=not tty and log_level not in ("debug", "info"),
        replan_from=flight.replan_from,
        show_plan=show_plan,
        inputs=flight.inputs,
        options=flight.options,
        item_numbers=flight.item_numbers,
    )


def _fly(
    prepared: Prepared,
    url: str,
    run_dir: Path | None,
    log_level: str,
    show_plan: bool,
    beside: SimConfig | None = None,
) -> None:
    """Run the daemon on the ``prepared`` flight; exits with its code. ``beside``: the embedded
    simulator to run in the daemon's own loop, on one simulated clock (``url`` is then the
    simulator's)."""
    cfg, flight = prepared.cfg, prepared.flight
    tty = sys.stderr.isatty()
    configure_logging(tty=tty, level=log_level)

    def options(url: str) -> RunOptions:
        return flight_options(cfg, flight, url, run_dir, log_level, show_plan, tty)

    if beside is None:
        outcome = eventloop.run(run_mission(options(url)), cfg.link.event_loop)
    else:
        flown = beside_simulator(beside, (), lambda url: run_mission(options(url)))
        outcome = eventloop.run(flown, simulated=True)
    if outcome.run_dir is not None:
        typer.echo(f"run directory: {outcome.run_dir}", err=True)
    for line in outcome.messages:  # the last one is the plain "helixd: RESULT" line
        typer.echo(line, err=True)
    raise typer.Exit(int(outcome.exit_code))


def _resume_source(
    ctx: typer.Context, mission: Path, run_dir: Path, not_allowed: Mapping[str, object]
) -> Resume:
    """``--resume RUN_DIR``: the recorded mission as it was; the options that would change it
    are a usage error."""
    given = [name for name, used in not_allowed.items() if used]
    if given:
        raise fail(
            [f"--resume flies the recorded mission as it was: {', '.join(given)} not allowed"],
            ExitCode.USAGE,
        )
    return Resume(run_dir, _explicit_mission(ctx, mission))


def _explicit_mission(ctx: typer.Context, mission: Path) -> Path | None:
    """``--mission`` when the operator gave it (with --resume it must be the same mission)."""
    source = ctx.get_parameter_source("mission")
    if source is None or source.name == "DEFAULT":
        return None
    return mission


def prepared_or_exit(
    source: FlightSource, config: Path | None, occupancy: OccupancyMap | Path | None
) -> Prepared:
    """:func:`prepare_flight`, its notes on stderr; refused: the notes, the ``error:`` lines
    and the exit."""
    try:
        got = prepare_flight(source, config, occupancy)
    except InputsRefused as exc:
        echo_notes(exc.notes)
        raise refused(exc) from None
    echo_notes(got.notes)
    return got


def echo_notes(notes: tuple[str, ...]) -> None:
    """Warnings and notes about the inputs, on stderr."""
    for line in notes:
        typer.echo(line, err=True)


def echo_flight(flight: Flight) -> None:
    """The planned legs, when the flight was planned around obstacles."""
    if flight.route is not None:
        typer.echo("\n".join(route_lines(flight.route, flight.mission)))


@app.command()
def status(
    connect: ObserverConnectOpt = None,
    config: ConfigOpt = None,
    watch: Annotated[bool, typer.Option("--watch", help="refresh until Ctrl-C")] = False,
    interval_s: Annotated[float, typer.Option(min=0.2, max=60.0, help="refresh period (s)")] = 1.0,
) -> None:
    """Print mode, armed, pose, EKF health, RC inputs and servo outputs (read-only)."""
    cfg = config_or_exit(config)
    url = check_connect(connect, cfg)
    held = HeldLog()  # its warnings come after the report, as its own lines, not among them
    configure_logging(tty=False, level="warning", stream=held)
    link = cfg.link.model_copy(update={"url": url})
    try:
        code = asyncio.run(
            read_status(
                link,
                cfg.safety,
                cfg.startup.connect_timeout_s,
                watch,
                interval_s,
                typer.echo,
                held,
            )
        )
    except LinkError as exc:
        _echo_held(held)
        raise fail([str(exc)], ExitCode.LINK) from None
    except KeyboardInterrupt:
        code = 0
    _echo_held(held)
    raise typer.Exit(code)


def _echo_held(held: HeldLog) -> None:
    for line in log_lines(held.drain()):
        typer.echo(line, err=True)


# Every command module's register(app) adds its commands to the Typer it is given; the
# groups are made here. Commands are listed in --help in this order, groups after them.
cli_sim.register(app)
cli_runs.register(app)
cli_serve.register(app)
cli_plant.register(app)
cli_survey_map.register(app)
cli_ground.register(app)
mission_app = command_group(
    "mission",
    "Mission files: convert between helixd YAML, QGroundControl .plan and .waypoints; "
    "generate surveys.",
    rich_markup_mode=None,
    cls=WholeHelpGroup,
)
cli_mission.register(mission_app)
app.add_typer(mission_app, name="mission")
autopilot_app = command_group("autopilot", "Set the autopilot up for helixd.")
cli_guard.register(autopilot_app)
cli_autopilot_check.register(autopilot_app)
cli_autopilot_setup.register(autopilot_app)
app.add_typer(autopilot_app, name="autopilot")


NOT_A_CHOICE = re.compile(
    r"^Invalid value for '(?P<option>[^']+)': (?:Value error, )?'(?P<value>[^']*)' is not one "
    r"of (?P<choices>.+?)\.?$"
)


def usage_message(text: str) -> str:
    """A command-line error as the operator reads it: a choice not among an option's choices
    says them plainly (``--mode 'rol' is not one of: roll, scroll, omni``), not the parser's
    ``Invalid value for '--mode': Value error, 'rol' is not one of 'roll', …``."""
    got = NOT_A_CHOICE.match(text)
    if got is None:
        return text.replace("Value error, ", "")
    choices = ", ".join(
        c.strip().strip("'") for c in re.split(r",| or ", got["choices"]) if c.strip()
    )
    return f"{got['option']} {got['value']!r} is not one of: {choices}"


def main(argv: list[str] | None = None) -> None:
    """Entry point. Command-line errors (typer/click usage errors) become one ``error:`` line
    and exit 2, like every other validation error, instead of a usage box."""
    args = sys.argv[1:] if argv is None else argv
    args = args or ["--help"]  # bare `helixd`: the help, as no_args_is_help would show it
    try:
        code = app(args=args, standalone_mode=False)
    except TyperException as exc:  # click's UsageError/BadParameter/NoSuchOption, ...
        typer.echo(f"error: {clip_line(usage_message(exc.format_message()))}", err=True)
        code = int(exc.exit_code)
    sys.exit(code if isinstance(code, int) else 0)


if __name__ == "__main__":
    main()
