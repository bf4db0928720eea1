"""The autopilot's mission as helixd flies it: downloaded items → a validated mission.

Shared by ``helixd run --mission autopilot`` (:mod:`helixd.cli.autopilot`, which prints the
notes and turns a refusal into exit 3) and ``helixd serve`` (:mod:`helixd.serve.service`,
which tells the ground station). Pure: no link, no printing.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

from pydantic import ValidationError

from helixd.base.plan import MotionMode
from helixd.base.problems import Problems
from helixd.config.root import HelixdConfig
from helixd.files.models import format_validation_error
from helixd.mav.mission_item import MissionItem
from helixd.mission.formats import LoadedMission, MissionFormat, read_fence, with_fence
from helixd.mission.formats.items import FormatError, GcsMission, items_to_mission
from helixd.mission.formats.wire import wire_to_gcs
from helixd.mission.model import Mission

__all__ = [
    "MISSION_NAME",
    "FromAutopilot",
    "MissionRefused",
    "convert_download",
    "ground_station_mode",
    "items_sha256",
]

MISSION_NAME = "autopilot"


class MissionRefused(Problems):
    """The autopilot's mission cannot be flown; one human line per problem."""

    joiner = "; "


@dataclass(frozen=True)
class FromAutopilot:
    mission: Mission
    source: str  # "autopilot at URL", for messages
    items: int  # mission items after home
    fence_shapes: int
    fence: GcsMission | None = None  # the autopilot's fence (and --fence's), for planning
    notes: tuple[str, ...] = ()  # what the conversion warns about (dropped fields, …)


def ground_station_mode(cfg: HelixdConfig, mode: MotionMode | None) -> MotionMode | None:
    """``--mode``, else ``mission.ground_station_mode`` (a GCS mission carries no motion
    mode); None when neither says."""
    if mode is not None:
        return mode
    gs = cfg.mission.ground_station_mode
    return MotionMode(gs) if gs else None


def items_sha256(mission: tuple[MissionItem, ...], fence: tuple[MissionItem, ...]) -> str:
    """A fingerprint of what the autopilot stores (mission after home, and fence): equal
    fingerprints, the same mission. Home (row 0) is left out: ArduPilot rewrites it."""
    h = hashlib.sha256()
    for part, items in (("mission", mission[1:]), ("fence", fence)):
        h.update(part.encode())
        for item in items:
            h.update(repr(item).encode())
    return h.hexdigest()


def convert_download(
    got_mission: tuple[MissionItem, ...],
    got_fence: tuple[MissionItem, ...],
    *,
    source: str,
    cfg: HelixdConfig,
    mode: MotionMode,
    fence: Path | None = None,
) -> FromAutopilot:
    """Downloaded items → a validated mission; :class:`MissionRefused` says why not."""
    route = cfg.planning.enabled
    try:
        gcs, notes = wire_to_gcs(got_mission, got_fence)
        if not gcs.items:
            raise FormatError(["the autopilot holds no mission (only home): nothing to fly"])
        conv = items_to_mission(
            gcs, name=MISSION_NAME, mode=mode, source=source, route_keep_outs=route
        )
        # the range checks a mission file gets from the loader
        msn = Mission.model_validate(conv.mission.model_dump(), context={"limits": cfg.mission})
        loaded = LoadedMission(msn, MissionFormat.PLAN, conv.notes, gcs)
        if fence is not None:
            loaded = with_fence(loaded, read_fence(fence), str(fence), route_keep_outs=route)
            msn = loaded.mission
    except FormatError as exc:
        raise MissionRefused(
            [p if p.startswith(source) else f"{source}: {p}" for p in exc.problems]
        ) from None
    except ValidationError as exc:
        raise MissionRefused(format_validation_error(source, exc, Mission)) from None
    shapes = len(gcs.polygons) + len(gcs.circles)
    return FromAutopilot(msn, source, len(gcs.items), shapes, loaded.gcs, (*notes, *loaded.notes))
