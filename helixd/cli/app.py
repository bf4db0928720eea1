"""Command-line interface: ``helixd run | check | sim | status | plot | replay | version``.

Errors the operator can fix (bad file, bad URL, refused preflight) are printed as one clear
message per problem and a non-zero exit code — never a traceback.
"""

from __future__ import annotations

import contextlib
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from typer.exceptions import TyperException

from helixd import __version__
from helixd.base.exitcodes import ExitCode
from helixd.cli import mission as cli_mission
from helixd.cli import runs as recorder_command
from helixd.cli.common import config_or_exit, fail
from helixd.config import ConfigFileError, HelixdConfig, load_config
from helixd.files.yamlio import clip_line, paused_gc
from helixd.mission import Mission, MissionFrameKind, MotionMode, Plan, PlanError
from helixd.mission.formats import MissionFormat, load_mission_file, mission_to_yaml, sniff_format
from helixd.mission.locate import MissionNotFound, locate_mission
from helixd.mission.validate import (
    apply_mission_limits,
    mission_problems,
    pending_checks,
    plan_for_check,
)
from helixd.sim import command as sim_command
from helixd.sim.config import NoiseLevel, Plant, Terrain

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator

    from helixd.mission.resume import RunInputs
    from helixd.planning.mapfile import OccupancyMap
    from helixd.planning.route import RoutePlan
    from helixd.sim.obstacles import SimObstacles

app = typer.Typer(
    name="helixd",
    help="Fly the Helix-25 screw-propelled rover through waypoint missions over MAVLink.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

ConfigOpt = Annotated[
    Path | None,
    typer.Option("--config", "-c", help="helixd.yaml (defaults built in when omitted)"),
]
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
ModeOpt = Annotated[
    MotionMode | None,
    typer.Option(
        "--mode",
        help="motion mode for a .plan/.waypoints mission (default: "
        "mission.ground_station_mode); overrides a YAML mission's mode",
    ),
]
SkipOpt = Annotated[
    bool,
    typer.Option(
        "--skip-unsupported",
        help="leave out .plan/.waypoints items helixd cannot fly (listed) instead of refusing",
    ),
]
MAX_TABLE_ROWS = 200  # `check` lists at most this many waypoints (first and last ones)
MapOpt = Annotated[
    Path | None,
    typer.Option(
        "--map",
        help="ROS map_server map (YAML + PGM/PNG, x east / y north from the EKF origin): plan "
        "every leg around it and the planning.keep_out_* shapes (local_ned missions)",
    ),
]


def load_inputs(
    config: Path | None,
    mission: Path,
    mode: MotionMode | None = None,
    skip_unsupported: bool = False,
) -> tuple[HelixdConfig, Mission, Path, tuple[Plan, bool]]:
    """Load config and mission together so the operator sees every problem at once.

    Runs the shared mission-vs-config validation (what can be checked without the vehicle),
    so ``check`` and ``run`` refuse the same files. Returns the mission file actually used and
    the plan as :func:`plan_for_check` resolves it.
    """
    problems: list[str] = []
    cfg: HelixdConfig | None = None
    try:
        cfg = load_config(config)
    except ConfigFileError as exc:
        problems.extend(exc.problems)
    limits = cfg.mission if cfg is not None else HelixdConfig().mission
    msn = None
    path = mission
    try:
        found = locate_mission(mission)
        path = found.path
        if found.searched:
            typer.echo(f"mission {mission}: using {path}", err=True)
        gs_mode = cfg.mission.ground_station_mode if cfg is not None else None
        loaded = load_mission_file(
            path,
            limits,
            mode=mode,
            default_mode=MotionMode(gs_mode) if gs_mode else None,
            skip_unsupported=skip_unsupported,
            # planning routes the legs around a .plan's exclusion zones instead of refusing
            route_keep_outs=cfg is not None and cfg.planning.enabled,
        )
        msn = loaded.mission
        for line in (*loaded.skipped, *loaded.notes):
            typer.echo(f"warning: {clip_line(line)}", err=True)
    except MissionNotFound as exc:
        problems.append(str(exc))
    except ConfigFileError as exc:
        problems.extend(exc.problems)
    checked: tuple[Plan, bool] | None = None
    if cfg is not None and msn is not None:
        checked = mission_vs_config(cfg, msn, str(path), problems)
    if problems or cfg is None or msn is None or checked is None:
        raise fail(problems, ExitCode.USAGE)
    # the mission's own fence/time limit (a survey's) replace the config's for this run
    cfg = apply_mission_limits(cfg, msn)
    return cfg, msn, path, checked


def mission_vs_config(
    cfg: HelixdConfig, msn: Mission, label: str, problems: list[str]
) -> tuple[Plan, bool] | None:
    """The plan as :func:`plan_for_check` resolves it, and the mission-vs-config checks
    (what can be checked without the vehicle); problems are appended, prefixed by ``label``."""
    try:
        with paused_gc():  # large acyclic plan: see yamlio.paused_gc
            checked = plan_for_check(msn, cfg)
    except PlanError as exc:
        problems.append(f"{label}: {exc}")
        return None
    refused = mission_problems(msn, cfg, checked_plan=checked)
    problems.extend(f"{label}: {p}" for p in refused)
    return checked


def plan_inputs(
    cfg: HelixdConfig, msn: Mission, path: Path, map_path: Path | None
) -> tuple[Mission, RoutePlan | None]:
    """Plan around the map and keep-out shapes (helixd.planning) when there are any: the
    mission with the intermediate waypoints inserted, and the route; refusals exit 2."""
    return plan_loaded(cfg, msn, path, load_occupancy(cfg, map_path))


def load_occupancy(cfg: HelixdConfig, map_path: Path | None) -> OccupancyMap | None:
    """The ``--map`` (helixd.planning.mapfile), or None; an unusable map exits 2."""
    from helixd.planning import MapFileError, load_map

    if map_path is None:
        return None
    try:
        return load_map(map_path, cfg.planning.max_cells)
    except MapFileError as exc:
        raise fail([str(exc)], ExitCode.USAGE) from None


def plan_loaded(
    cfg: HelixdConfig, msn: Mission, path: Path, occupancy: OccupancyMap | None
) -> tuple[Mission, RoutePlan | None]:
    """:func:`plan_inputs` with the map already loaded."""
    from helixd.planning import (
        MapFileError,
        ObstacleError,
        PlanningError,
        plan_mission,
        planning_wanted,
    )

    try:
        if msn.frame is MissionFrameKind.GLOBAL and cfg.planning.enabled:
            return plan_global(cfg, msn, path, occupancy)
        if not planning_wanted(cfg, occupancy):
            return msn, None
        return plan_mission(msn, cfg, occupancy)
    except PlanningError as exc:
        raise fail([f"{path}: {p}" for p in exc.problems], ExitCode.USAGE) from None
    except (MapFileError, ObstacleError) as exc:
        raise fail([str(exc)], ExitCode.USAGE) from None


def plan_global(
    cfg: HelixdConfig, msn: Mission, path: Path, occupancy: OccupancyMap | None
) -> tuple[Mission, RoutePlan | None]:
    """A global mission: planned around its .plan's exclusion zones when it has any (in a
    frame around waypoint 0, helixd.planning.fence); with only a --map or config keep-outs,
    refused (they hang from the unknown EKF origin); else flown as it is."""
    from helixd.mission.formats import has_keep_outs, plan_fence_ne
    from helixd.planning import KeepOutCircle, planning_wanted
    from helixd.planning.fence import plan_global_mission

    own = has_keep_outs(path)
    if not (own or planning_wanted(cfg, occupancy)):
        return msn, None
    origin = msn.points()[0]
    polys: list[tuple[tuple[float, float], ...]] = []
    circles: list[KeepOutCircle] = []
    if own:
        fence = plan_fence_ne(path, origin)
        polys = list(fence.exclusion_polygons)
        circles = [
            KeepOutCircle(c.centre_ne_m[0], c.centre_ne_m[1], c.radius_m)
            for c in fence.exclusion_circles
        ]
    return plan_global_mission(msn, cfg, polys, circles, origin, occupancy)


def sim_world(
    cfg: HelixdConfig, occupancy: OccupancyMap | None, mission_path: Path | None = None
) -> SimObstacles:
    """What is solid in the embedded simulator (``run --sim``): the config's keep-out shapes,
    the map's occupied cells (unknown is not solid) and a .plan's exclusion zones (placed
    around the simulator's EKF origin); the body radius from the vehicle."""
    from helixd.config import KeepOutCircleConfig
    from helixd.mission.formats import has_keep_outs, plan_fence_ne
    from helixd.planning.obstacles import rover_half_width_m
    from helixd.sim.config import SimConfig
    from helixd.sim.obstacles import ObstacleRaster, SimObstacles

    polys: list[tuple[tuple[float, float], ...]] = []
    discs: list[KeepOutCircleConfig] = []
    if mission_path is not None and has_keep_outs(mission_path):
        sim = SimConfig()
        fence = plan_fence_ne(mission_path, (sim.origin_lat_deg, sim.origin_lon_deg))
        polys.extend(fence.exclusion_polygons)
        discs.extend(
            KeepOutCircleConfig(
                north_m=c.centre_ne_m[0], east_m=c.centre_ne_m[1], radius_m=c.radius_m
            )
            for c in fence.exclusion_circles
        )

    raster = None
    if occupancy is not None:
        fr = occupancy.frame
        raster = ObstacleRaster(
            fr.origin_north_m, fr.origin_east_m, fr.resolution_m, occupancy.solid.astype(bool)
        )
    pl = cfg.planning
    return SimObstacles(
        polygons_ne_m=(*(p for p in pl.keep_out_polygons_ne_m if p), *polys),
        circles=(*pl.keep_out_circles, *discs),
        contact_radius_m=rover_half_width_m(cfg),
        raster=raster,
    )


def first_leg_replanner(
    cfg: HelixdConfig, original: Mission, planned: Mission, route: RoutePlan
) -> Callable[[tuple[float, float], tuple[float, float] | None], Mission]:
    """What the daemon calls at preflight with the rover's (north_m, east_m) and the EKF
    origin: the planned
    mission with its first leg re-planned from there (helixd.planning.replan); raises
    PlanningError (a ValueError) naming the pose when it cannot."""
    from helixd.planning.replan import replan_first_leg

    def replan_from(
        rover_ne_m: tuple[float, float], ekf_origin_latlon_deg: tuple[float, float] | None
    ) -> Mission:
        from helixd.base.frames import latlon_to_ne, ne_to_latlon
        from helixd.planning import PlanningError

        here = rover_ne_m
        if route.origin_latlon_deg is not None:  # a global mission's route: around waypoint 0
            if ekf_origin_latlon_deg is None:
                raise PlanningError(["a global mission's first leg needs the EKF origin"])
            latlon = ne_to_latlon(*rover_ne_m, *ekf_origin_latlon_deg)
            here = latlon_to_ne(*latlon, *route.origin_latlon_deg)
        again, again_route = replan_first_leg(planned, route, original, here, cfg)
        if again is not planned:
            import structlog

            leg = again_route.legs[0]
            structlog.get_logger("helixd.planning").info(
                "first_leg_replanned",
                rover_north_m=round(rover_ne_m[0], 2),
                rover_east_m=round(rover_ne_m[1], 2),
                vias=len(leg.points_ne_m) - 2,
                length_m=round(leg.length_m, 2),
            )
        return again

    return replan_from


def echo_route(route: RoutePlan) -> None:
    """The planned legs, one line each, with their intermediate points."""
    fr = route.grid.frame
    typer.echo(
        f"planned : clearance {route.grid.clearance_m:.2f} m (rover half-width + "
        f"planning.margin_m), grid {fr.rows} × {fr.cols} at {fr.resolution_m:g} m, "
        f"{route.seconds * 1000:.0f} ms"
    )
    for leg in route.legs:
        a = "start" if leg.from_index < 0 else f"wp {leg.from_index}"
        via = leg.points_ne_m[1:-1]
        straight = math.dist(leg.points_ne_m[0], leg.points_ne_m[-1])
        how = "straight" if not via else f"{len(via)} intermediate, straight {straight:.1f} m"
        typer.echo(f"  leg {a} → wp {leg.to_index}: {leg.length_m:.1f} m ({how})")
        for n, e in via:
            typer.echo(f"      via north {n:9.2f}  east {e:9.2f}")
    total = sum(leg.length_m for leg in route.legs)
    start = "planning.start_ne_m" if route.origin_latlon_deg is None else "waypoint 0"
    typer.echo(f"  total {total:.1f} m from {start} (run: re-planned from the rover's pose)")


def check_connect(connect: str | None, cfg: HelixdConfig) -> str:
    """The link URL to use: ``--connect`` if given (validated; empty is an error), else the
    config's (validated when the config loaded)."""
    if connect is None:
        return cfg.link.url
    from helixd.mav.url import LinkError, parse_link_url

    try:
        parse_link_url(connect, cfg.link.baud)
    except LinkError as exc:
        raise fail([f"--connect: {exc}"], ExitCode.USAGE) from None
    return connect.strip()


@app.command()
def version() -> None:
    """Print the helixd version."""
    typer.echo(f"helixd {__version__}")


@app.command()
def check(
    config: ConfigOpt = None,
    mission: MissionOpt = Path("mission.yaml"),
    map_path: MapOpt = None,
    plot: Annotated[
        Path | None,
        typer.Option("--plot", help="with planning: draw map, inflation and path to this PNG"),
    ] = None,
    mode: ModeOpt = None,
    skip_unsupported: SkipOpt = False,
) -> None:
    """Validate the config and a mission (as `run` would), and print the resolved plan."""
    cfg, msn, path, (plan, provisional) = load_inputs(config, mission, mode, skip_unsupported)
    _, route = plan_inputs(cfg, msn, path, map_path)
    note = (
        " (global: shown relative to waypoint 0; the EKF origin is used in flight)"
        if provisional
        else ""
    )
    axes = (
        "x forward / y left of start" if msn.frame is MissionFrameKind.START else "x east / y north"
    )
    typer.echo(f"config  : {config or '(built-in defaults)'}  OK")
    typer.echo(f"mission : {path}  OK")
    typer.echo(f"plan    : {plan.name}  mode={plan.mode.value}  frame={plan.frame.value}{note}")
    typer.echo(f"axes    : {axes} (metres)")
    rows = [f"{'#':>3} {'x_m':>9} {'y_m':>9} {'tol_m':>6} {'heading_deg':>11}"]
    count = len(plan.waypoints)
    head = count if count <= MAX_TABLE_ROWS else MAX_TABLE_ROWS // 2
    for i, wp in enumerate(plan.waypoints):
        if head <= i < count - (MAX_TABLE_ROWS - head):
            if i == head:
                rows.append(f"... {count - MAX_TABLE_ROWS} waypoints not shown ...")
            continue
        hdg = "-" if wp.final_yaw_rad is None else f"{math.degrees(wp.final_yaw_rad):.1f}"
        rows.append(f"{i:>3} {wp.x_m:>9.2f} {wp.y_m:>9.2f} {wp.tolerance_m:>6.2f} {hdg:>11}")
    typer.echo("\n".join(rows))
    # start frame: from the start point; ENU frames: from waypoint 0 (the start pose is not
    # known yet), as mission_problems() estimates it.
    first = plan.waypoints[0]
    start = (0.0, 0.0) if msn.frame is MissionFrameKind.START else (first.x_m, first.y_m)
    length = plan.path_length_m(start)
    eta = plan.estimated_time_s(cfg.control.max_yaw_rate_radps, start)
    origin_note = "" if msn.frame is MissionFrameKind.START else " (from waypoint 0)"
    typer.echo(f"path    : {length:.1f} m at {plan.speed_mps:.2f} m/s{origin_note}")
    typer.echo(
        f"estimate: {eta:.0f} s ({eta / 60:.1f} min; limit "
        f"safety.mission_time_limit_s = {cfg.safety.mission_time_limit_s:.0f} s)"
    )
    own = [
        *(
            [f"geofence polygon ({len(msn.geofence_polygon)} vertices)"]
            if msn.geofence_polygon
            else []
        ),
        *([f"geofence radius {msn.geofence_radius_m} m"] if msn.geofence_radius_m else []),
        *([f"time limit {msn.time_limit_s:.0f} s"] if msn.time_limit_s is not None else []),
    ]
    if own:
        typer.echo(f"limits  : the mission's own {', '.join(own)} replace the config's")
    later = pending_checks(msn, cfg)
    if later:
        typer.echo(f"preflight: run checks with the start pose: {', '.join(later)}")
    if route is not None:
        echo_route(route)
        if plot is not None:
            from helixd.recorder.plots import render_route

            try:
                typer.echo(f"plot    : {render_route(route, plot, title=plan.name)}")
            except OSError as exc:
                raise fail([f"--plot: cannot write {plot}: {exc}"], ExitCode.USAGE) from None


@app.command()
def run(
    mission: MissionOpt = Path("mission.yaml"),
    config: ConfigOpt = None,
    connect: Annotated[
        str | None,
        typer.Option(
            "--connect",
            help="autopilot link: /dev/ttyACM0[:baud], udpin:HOST:PORT, udpout:HOST:PORT, "
            "tcp:HOST:PORT (default: link.url from the config)",
        ),
    ] = None,
    sim: Annotated[
        bool, typer.Option("--sim", help="fly against the built-in simulator, started in-process")
    ] = False,
    sim_speedup: Annotated[
        float, typer.Option(min=0.1, max=20.0, help="simulator speed-up factor (with --sim)")
    ] = 1.0,
    sim_terrain: Annotated[
        Terrain, typer.Option(help="simulator terrain (with --sim)")
    ] = Terrain.HARD,
    sim_plant: Annotated[
        Plant,
        typer.Option(
            help="simulator vehicle model (with --sim); sitl_skid needs the SITL channel "
            "mapping in --config (tests/sitl/README.md)"
        ),
    ] = Plant.HELIX,
    sim_noise: Annotated[
        NoiseLevel, typer.Option(help="simulator pose noise (with --sim)")
    ] = NoiseLevel.LOW,
    run_dir: Annotated[
        Path | None,
        typer.Option("--run-dir", help="root for run directories (default: recorder.run_root)"),
    ] = None,
    log_level: Annotated[str, typer.Option(help="debug, info, warning or error")] = "info",
    map_path: MapOpt = None,
    mode: ModeOpt = None,
    skip_unsupported: SkipOpt = False,
    show_plan: Annotated[
        bool,
        typer.Option(
            "--show-plan",
            help="upload the resolved plan as the autopilot's mission so the ground station "
            "draws the path (helixd never switches to AUTO, so ArduPilot never flies it)",
        ),
    ] = False,
    resume: Annotated[
        Path | None,
        typer.Option(
            "--resume",
            help="continue the mission of this run directory from its first waypoint not "
            "reached (refused if the mission or config changed, or the run completed)",
        ),
    ] = None,
) -> None:
    """Fly a mission: connect, preflight, arm, fly, and always stop + release + HOLD.

    ``--mission autopilot`` flies the mission the autopilot holds (downloaded over MAVLink);
    ``--resume RUN_DIR`` continues a recorded run (helixd.mission.resume)."""
    from helixd.cli.autopilot import wants_autopilot

    if sim and connect is not None:
        raise fail(["--sim and --connect exclude each other"], ExitCode.USAGE)
    occupancy: OccupancyMap | None = None
    if resume is not None:
        given = [
            name
            for name, used in (
                ("--mode", mode),
                ("--map", map_path),
                ("--skip-unsupported", skip_unsupported),
            )
            if used
        ]
        if given:
            raise fail(
                [f"--resume flies the recorded mission as it was: {', '.join(given)} not allowed"],
                ExitCode.USAGE,
            )
        explicit = _explicit_mission(mission)
        cfg, msn, mission_yaml, inputs = resume_inputs(config, resume, explicit)
        url = check_connect(connect, cfg)
        # the recorded mission is already planned: no map, no first-leg replanning
        mission_path = resume / "mission.yaml"
        flight = _Flight(msn, mission_yaml, None, inputs)
    elif wants_autopilot(mission):
        _run_autopilot_mission(
            config, connect, sim, SimChoice(sim_speedup, sim_terrain, sim_plant, sim_noise),
            run_dir, log_level, map_path, mode, skip_unsupported, show_plan,
        )  # fmt: skip
        return  # not reached: it exits with the run's code
    else:
        cfg, msn, mission_path, _ = load_inputs(config, mission, mode, skip_unsupported)
        url = check_connect(connect, cfg)
        mission_yaml = _recorded_mission_yaml(mission_path, msn, mode)
        occupancy = load_occupancy(cfg, map_path)
        # planned around obstacles; refusals before a simulator starts
        flight = _planned(cfg, msn, mission_yaml, mission_path, occupancy, config_sha256(config))
    sim_choice = SimChoice(sim_speedup, sim_terrain, sim_plant, sim_noise) if sim else None
    with _simulator(sim_choice, lambda: sim_world(cfg, occupancy, mission_path), url) as url:
        _fly(cfg, flight, url, run_dir, log_level, show_plan)


@dataclass(frozen=True)
class SimChoice:
    speedup: float
    terrain: Terrain
    plant: Plant
    noise: NoiseLevel


@contextlib.contextmanager
def _simulator(
    choice: SimChoice | None, world: Callable[[], SimObstacles], url: str
) -> Iterator[str]:
    """The link URL to fly on: ``url``, or (``--sim``) an embedded simulator's, started with
    ``world``'s obstacles and stopped on the way out."""
    if choice is None:
        yield url
        return
    from helixd.sim import SimConfig, start_embedded

    sim_cfg = SimConfig(
        speedup=choice.speedup,
        terrain=choice.terrain,
        noise=choice.noise,
        plant=choice.plant,
        obstacles=world(),
    )
    server, sim_url = start_embedded(sim_cfg)
    try:
        yield sim_url
    finally:
        server.stop()


def _run_autopilot_mission(
    config: Path | None,
    connect: str | None,
    sim: bool,
    sim_choice: SimChoice,
    run_dir: Path | None,
    log_level: str,
    map_path: Path | None,
    mode: MotionMode | None,
    skip_unsupported: bool,
    show_plan: bool,
) -> None:
    """``run --mission autopilot``: download, convert and check the autopilot's mission, then
    fly it as any other (see :mod:`helixd.cli.autopilot`). Refusals exit 3."""
    from helixd.cli.autopilot import AUTOPILOT_MISSION, fetch_autopilot_mission

    cfg = config_or_exit(config)
    url = check_connect(connect, cfg)
    occupancy = load_occupancy(cfg, map_path)
    with _simulator(sim_choice if sim else None, lambda: sim_world(cfg, occupancy), url) as url:
        got = fetch_autopilot_mission(cfg, url, mode, skip_unsupported)
        msn = got.mission
        problems: list[str] = []
        checked = mission_vs_config(cfg, msn, got.source, problems)
        if problems or checked is None:
            raise fail(problems, ExitCode.PREFLIGHT)
        cfg = apply_mission_limits(cfg, msn)
        mission_yaml = mission_to_yaml(msn)  # the run directory records what was downloaded
        path = Path(AUTOPILOT_MISSION)
        flight = _planned(cfg, msn, mission_yaml, path, occupancy, config_sha256(config))
        _fly(cfg, flight, url, run_dir, log_level, show_plan)


@dataclass(frozen=True)
class _Flight:
    """What is flown: the mission (planned around obstacles when there are any), the text the
    run directory records, and the first-leg re-planner for the daemon's preflight."""

    mission: Mission
    mission_yaml: str
    replan_from: Callable[[tuple[float, float], tuple[float, float] | None], Mission] | None
    inputs: RunInputs  # inputs.json: mission/config hashes (what --resume checks)


def _planned(
    cfg: HelixdConfig,
    msn: Mission,
    mission_yaml: str,
    mission_path: Path,
    occupancy: OccupancyMap | None,
    config_sha: str,
) -> _Flight:
    """Plan around the map and keep-outs (refusals exit 2) and print the legs."""
    from helixd.mission.resume import fresh_inputs

    planned, route = plan_loaded(cfg, msn, mission_path, occupancy)
    if route is None:
        return _Flight(msn, mission_yaml, None, fresh_inputs(mission_yaml, config_sha, msn))
    from helixd.planning.route import planned_mission_yaml

    map_path = None if occupancy is None else occupancy.source
    echo_route(route)
    planned_yaml = planned_mission_yaml(planned, route, map_path)
    return _Flight(
        planned,
        planned_yaml,
        first_leg_replanner(cfg, msn, planned, route),
        fresh_inputs(planned_yaml, config_sha, planned),
    )


def _fly(
    cfg: HelixdConfig,
    flight: _Flight,
    url: str,
    run_dir: Path | None,
    log_level: str,
    show_plan: bool,
) -> None:
    """Run the daemon; exits with its code."""
    import asyncio

    from helixd.recorder.logging_setup import configure_logging
    from helixd.runtime.daemon import RunOptions, run_mission

    tty = sys.stderr.isatty()
    configure_logging(tty=tty, level=log_level)
    cfg = cfg.model_copy(update={"link": cfg.link.model_copy(update={"url": url})})
    opts = RunOptions(
        cfg=cfg,
        mission=flight.mission,
        mission_yaml=flight.mission_yaml,
        connect_url=url,
        run_root=run_dir or cfg.recorder.run_root,
        tty=tty,
        replan_from=flight.replan_from,
        show_plan=show_plan,
        inputs=flight.inputs,
    )
    outcome = asyncio.run(run_mission(opts))
    if outcome.run_dir is not None:
        typer.echo(f"run directory: {outcome.run_dir}", err=True)
    for line in outcome.messages:  # the last one is the plain "helixd: RESULT" line
        typer.echo(line, err=True)
    raise typer.Exit(int(outcome.exit_code))


def _recorded_mission_yaml(mission_path: Path, msn: Mission, mode: MotionMode | None) -> str:
    """What the run directory keeps as mission.yaml (and hashes): the YAML file as written,
    else the flown mission as helixd YAML."""
    try:
        if sniff_format(mission_path) is MissionFormat.YAML and mode is None:
            return mission_path.read_text(encoding="utf-8")
        return mission_to_yaml(msn)
    except (OSError, UnicodeDecodeError) as exc:
        raise fail([f"{mission_path}: cannot read file: {exc}"], ExitCode.USAGE) from None


def config_sha256(config: Path | None) -> str:
    """Hash of the loaded config (canonical YAML dump: a value change is a change, a comment
    is not), before any command-line override such as --connect."""
    from helixd.config import config_to_yaml
    from helixd.mission.resume import sha256_text

    try:
        return sha256_text(config_to_yaml(load_config(config)))
    except ConfigFileError as exc:
        raise fail(exc.problems, ExitCode.USAGE) from None


def _explicit_mission(mission: Path) -> Path | None:
    """``--mission`` when the operator gave it (with --resume it must be the same mission)."""
    from typer._click.core import ParameterSource
    from typer._click.globals import get_current_context

    ctx = get_current_context(silent=True)
    if ctx is None or ctx.get_parameter_source("mission") is ParameterSource.DEFAULT:
        return None
    return mission


def resume_inputs(
    config: Path | None, run_dir: Path, explicit_mission: Path | None
) -> tuple[HelixdConfig, Mission, str, RunInputs]:
    """Config, remaining mission, its YAML and the new run's inputs record for
    ``--resume RUN_DIR``; every refusal is one line and exit 2."""
    from helixd.mission.resume import (
        ResumeRefused,
        check_inputs,
        parse_inputs,
        resume_point,
        resumed_inputs,
        sha256_text,
    )
    from helixd.recorder.resume_dir import MISSION_FILE, read_run_dir

    try:
        contents = read_run_dir(run_dir)
        recorded = parse_inputs(contents.inputs_text)
        explicit_sha = None
        if explicit_mission is not None:
            _, given, given_path, _ = load_inputs(config, explicit_mission)
            explicit_sha = sha256_text(_recorded_mission_yaml(given_path, given, None))
        check_inputs(recorded, contents.mission_yaml, config_sha256(config), explicit_sha)
        cfg, old, _, _ = load_inputs(config, run_dir / MISSION_FILE)
        point = resume_point(
            str(run_dir.resolve()), recorded, old, contents.events, contents.completed
        )
    except ResumeRefused as exc:
        raise fail([f"--resume {run_dir}: {exc}"], ExitCode.USAGE) from None
    mission_yaml = mission_to_yaml(point.mission)
    typer.echo(
        f"resume  : {run_dir}: from waypoint {point.first_index + 1}/"
        f"{recorded.waypoints_total} ({len(point.mission.waypoints)} remaining)",
        err=True,
    )
    if point.mission.frame is MissionFrameKind.LOCAL_NED:
        typer.echo(
            "warning: local_ned waypoints are relative to the EKF origin; if the autopilot "
            "set a new origin since (reboot, GPS), they lie elsewhere (global is safe)",
            err=True,
        )
    return cfg, point.mission, mission_yaml, resumed_inputs(point, mission_yaml)


@app.command()
def status(
    connect: Annotated[
        str | None, typer.Option("--connect", help="autopilot link (default: link.url)")
    ] = None,
    config: ConfigOpt = None,
    watch: Annotated[bool, typer.Option("--watch", help="refresh until Ctrl-C")] = False,
    interval_s: Annotated[float, typer.Option(min=0.2, max=60.0, help="refresh period (s)")] = 1.0,
) -> None:
    """Print mode, armed, pose, EKF health, RC inputs and servo outputs (read-only)."""
    import asyncio

    from helixd.link.connection import LinkError
    from helixd.recorder.logging_setup import configure_logging
    from helixd.runtime.status import read_status

    cfg = config_or_exit(config)
    url = check_connect(connect, cfg)
    configure_logging(tty=sys.stderr.isatty(), level="warning")
    link = cfg.link.model_copy(update={"url": url})
    try:
        code = asyncio.run(read_status(link, cfg.safety, watch, interval_s, typer.echo))
    except LinkError as exc:
        raise fail([str(exc)], ExitCode.LINK) from None
    except KeyboardInterrupt:
        code = 0
    raise typer.Exit(code)


sim_command.register(app)
recorder_command.register(app)
cli_mission.register(app)


def main(argv: list[str] | None = None) -> None:
    """Entry point. Command-line errors (typer/click usage errors) become one ``error:`` line
    and exit 2, like every other validation error, instead of a usage box."""
    from typer._click.exceptions import NoArgsIsHelpError

    try:
        code = app(args=argv, standalone_mode=False)
    except NoArgsIsHelpError as exc:
        exc.show()
        code = int(exc.exit_code)
    except TyperException as exc:  # click's UsageError/BadParameter/NoSuchOption, ...
        typer.echo(f"error: {clip_line(exc.format_message())}", err=True)
        code = int(exc.exit_code)
    sys.exit(code if isinstance(code, int) else 0)


if __name__ == "__main__":
    main()
