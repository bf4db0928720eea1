"""``run --sim``: the built-in simulator started in-process around a flight, with the world the
flight is planned in made solid (the CLI is the one layer that may import both the simulator
and the daemon)."""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass

from helixd.config import HelixdConfig, KeepOutCircleConfig
from helixd.mission.formats import GcsMission, fence_has_keep_outs, fence_ne
from helixd.planning import OccupancyMap
from helixd.planning.obstacles import rover_half_width_m
from helixd.sim import SimConfig, start_embedded
from helixd.sim.config import NoiseLevel, Plant, Terrain
from helixd.sim.obstacles import ObstacleRaster, SimObstacles


@dataclass(frozen=True)
class SimChoice:
    speedup: float
    terrain: Terrain
    plant: Plant
    noise: NoiseLevel


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


@contextlib.contextmanager
def simulator(
    choice: SimChoice | None, world: Callable[[], SimObstacles], url: str
) -> Iterator[str]:
    """The link URL to fly on: ``url``, or (``--sim``) an embedded simulator's, started with
    ``world``'s obstacles and stopped on the way out."""
    if choice is None:
        yield url
        return
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
