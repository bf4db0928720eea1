"""``run --sim``: the built-in simulator started in-process around a flight, with the world the
flight is planned in made solid (the CLI is the one layer that may import both the simulator
and the daemon).

The embedded simulator is set up as the README asks a real vehicle to be, helixd-guard
included: installed, guarding the config's scroll outputs. Its timeout is stretched by the
speed-up (0.5 s of wall time), because helixd paces its HEARTBEAT on the wall clock while the
guard counts simulated time: at ``--sim-speedup 4`` a 5 Hz HEARTBEAT is 1.25 simulated seconds
apart and would trip a 0.5 s guard between two of them.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Awaitable, Callable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Annotated, Any, TypeVar

import structlog
import typer

from helixd.base.exitcodes import ExitCode
from helixd.base.media import MediaMap
from helixd.cli.common import fail, read_sim_ground
from helixd.config.mission import KeepOutCircleConfig
from helixd.config.root import HelixdConfig
from helixd.files.bathymetry import Bathymetry, read_bathymetry
from helixd.files.media import MediaMapError, read_media_map
from helixd.files.models import ConfigFileError
from helixd.mav.guard_script import (
    HXG_CHANS,
    HXG_TIMEOUT,
    MAX_OUTPUT,
    PARAM_DEFAULTS,
    TIMEOUT_MAX_MS,
)
from helixd.mission.formats import fence_has_keep_outs
from helixd.mission.formats.items import GcsMission, fence_ne
from helixd.planning.mapfile import OccupancyMap
from helixd.planning.obstacles import rover_half_width_m
from helixd.plant.collisions import ObstacleRaster, SimObstacles
from helixd.plant.ground import Terrain, TerrainTable
from helixd.plant.plant_config import Plant
from helixd.recorder.logging_setup import configure_logging
from helixd.sim.server import EMBEDDED_LINK, SimServer, embedded_url, start_embedded
from helixd.sim.sim_config import SPEEDUP_MAX, SPEEDUP_MIN, NoiseLevel, SimClock, SimConfig

T = TypeVar("T")


@dataclass(frozen=True)
class SimChoice:
    speedup: float
    terrain: Terrain
    plant: Plant
    noise: NoiseLevel
    # (north_m, east_m, yaw_ned_rad) the rover starts at: a resumed run's simulator puts it
    # where the interrupted run left it; None: the EKF origin, facing North
    start_ned: tuple[float, float, float] | None = None
    # more simulator links (``serve --sim-gcs``: a ground station beside helixd)
    extra_links: tuple[str, ...] = ()
    # the world's media by place (``run --sim-media``); None: ``terrain`` everywhere
    media: MediaMap | None = None
    # the wall clock (sped up by ``speedup``) or one simulated clock (``run --sim-clock``)
    clock: SimClock = SimClock.WALL
    seed: int | None = None  # the noise generator's seed; None: a new one each run
    # the pond's bottom under the world's water (``--sim-bathymetry``): a down-facing sonar
    bathymetry: Bathymetry | None = None
    # the world's ground per medium (``run --sim-ground``); None: the built-in table
    ground: TerrainTable | None = None


def with_sim(help_text: str, low: float | None = None, high: float | None = None) -> Any:
    """An option of ``run`` or ``serve`` for their simulator: the help says it needs --sim."""
    return typer.Option(min=low, max=high, help=f"{help_text} (with --sim)")


SpeedupOpt = Annotated[float, with_sim("simulator speed-up factor", SPEEDUP_MIN, SPEEDUP_MAX)]
TerrainOpt = Annotated[Terrain, with_sim("simulator terrain")]
SimMediaOpt = Annotated[
    Path | None,
    typer.Option(
        "--sim-media",
        help="media map (GeoJSON or KML: hard, grass, sand, mud, water areas) for the simulator's "
        "world, each scroll in the medium under it; --sim-terrain outside (with --sim)",
    ),
]


def with_sim_files(
    choice: SimChoice | None,
    media: Path | None,
    ground: Path | None = None,
    bathymetry: Path | None = None,
) -> SimChoice | None:
    """``choice`` with the world's media map, ground and bathymetry files read (``--sim-media``,
    ``--sim-ground``, ``--sim-bathymetry``); a usage error when one is given without ``--sim``."""
    given = (("--sim-media", media), ("--sim-ground", ground), ("--sim-bathymetry", bathymetry))
    for flag, path in given:
        if path is not None and choice is None:
            raise fail([f"{flag} needs --sim"], ExitCode.USAGE)
    if choice is None:
        return None
    if media is not None:
        choice = replace(choice, media=read_sim_media(media))
    if ground is not None:
        choice = replace(choice, ground=read_sim_ground(ground))
    if bathymetry is not None:
        choice = replace(choice, bathymetry=read_sim_bathymetry(bathymetry))
    return choice


def read_sim_media(path: Path) -> MediaMap:
    """``--sim-media FILE`` read, or a usage error with one line per problem."""
    try:
        return read_media_map(path)
    except MediaMapError as exc:
        raise fail([f"--sim-media: {line}" for line in exc.problems], ExitCode.USAGE) from None


def read_sim_bathymetry(path: Path) -> Bathymetry:
    """``--sim-bathymetry FILE`` read, or a usage error with one line per problem."""
    try:
        return read_bathymetry(path)
    except ConfigFileError as exc:
        raise fail([f"--sim-bathymetry: {line}" for line in exc.problems], ExitCode.USAGE) from None


def sim_world(
    cfg: HelixdConfig, occupancy: OccupancyMap | None, fence_gcs: GcsMission | None = None
) -> SimObstacles:
    """What is solid in the embedded simulator (``run --sim``): the config's keep-out shapes,
    the map's occupied cells (unknown is not solid) and the fence's exclusion zones (a
    .plan's, --fence's; placed around the simulator's EKF origin); the body radius from the
    vehicle."""
    polys: list[tuple[tuple[float, float], ...]] = []
    discs: list[KeepOutCircleConfig] = []
    if fence_gcs is not None and fence_has_keep_outs(fence_gcs):
        sim = SimConfig()
        fence = fence_ne(fence_gcs, (sim.origin_lat_deg, sim.origin_lon_deg))
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


def embedded_guard(cfg: HelixdConfig, speedup: float) -> dict[str, float]:
    """helixd-guard's stored settings in the embedded simulator: the config's scroll outputs
    (those it can guard), the default timeout in wall seconds (see the module docstring)."""
    timeout_s = min(PARAM_DEFAULTS[HXG_TIMEOUT] * speedup, TIMEOUT_MAX_MS / 1000.0)
    chans = [ch.channel if ch.channel <= MAX_OUTPUT else 0 for ch in cfg.actuation.channels]
    return {HXG_TIMEOUT: timeout_s, **dict(zip(HXG_CHANS, map(float, chans), strict=True))}


def simulator_config(
    choice: SimChoice, world: Callable[[], SimObstacles], cfg: HelixdConfig
) -> SimConfig:
    """The embedded simulator ``choice`` asks for, with ``world``'s obstacles and helixd-guard
    installed. On the simulated clock both sides keep one time, so nothing is stretched."""
    speedup = 1.0 if choice.clock is SimClock.SIMULATED else choice.speedup
    start = {}
    if choice.start_ned is not None:
        north, east, yaw = choice.start_ned
        start = {"initial_north_m": north, "initial_east_m": east, "initial_yaw_ned_rad": yaw}
    return SimConfig(
        speedup=speedup,
        terrain=choice.terrain,
        noise=choice.noise,
        seed=choice.seed,
        plant=choice.plant,
        obstacles=world(),
        **start,
        guard_installed=True,
        guard_params=embedded_guard(cfg, speedup),
        media=choice.media,
        bathymetry=choice.bathymetry,
        **({} if choice.ground is None else {"terrains": choice.ground}),
    )


def _console_logging() -> None:
    if not structlog.is_configured():  # the run's console format from the first line on
        configure_logging(tty=sys.stderr.isatty())


@contextlib.contextmanager
def simulator(
    choice: SimChoice | None, world: Callable[[], SimObstacles], url: str, cfg: HelixdConfig
) -> Iterator[str]:
    """The link URL to fly on: ``url``, or (``--sim``) an embedded simulator's on its own
    thread, started with ``world``'s obstacles and helixd-guard installed, and stopped on the
    way out."""
    if choice is None:
        yield url
        return
    _console_logging()
    # a machine that does not keep the speed-up is said so at once and the speed-up lowered,
    # rather than another flight flown (helixd.sim.pace)
    config = simulator_config(choice, world, cfg)
    server, sim_url = start_embedded(config, choice.extra_links, judge_pace=True)
    try:
        yield sim_url
    finally:
        server.stop()


async def beside_simulator(
    config: SimConfig, extra_links: tuple[str, ...], fly: Callable[[str], Awaitable[T]]
) -> T:
    """``fly(url)`` with the embedded simulator running in the same event loop (the simulated
    clock: :class:`helixd.base.clock.SimulatedClockLoop`)."""
    _console_logging()
    server = SimServer([EMBEDDED_LINK, *extra_links], config, embedded=True)
    async with server.running_here():
        return await fly(embedded_url(server))
