"""A flight's media map and its plan split by it (:class:`helixd.planning.media_modes.MediaPlan`,
the mode per stretch): the shell around :mod:`helixd.planning.media_modes` that reads the map,
builds the mode policy and places the map with the EKF origin and the rover's start.

Which map: the mission's ``media_map`` (relative to the mission file), else the config's
``media.media_map`` (relative to the working directory); none: the mission's one mode
everywhere, exactly as before. ``check``, ``run`` and ``serve`` read it in
:func:`helixd.prepare.builder.prepare_flight` (an unreadable or bad map is refused there, one
line per problem naming the file and the feature); preflight reads it again and places it
with the EKF origin and the rover's start (:func:`placed_media_plan`).

A ``global`` (lat/lon) map needs the EKF origin: ``check`` stands in waypoint 1 of a global
mission (as it does for the mission itself); a ``local_ned`` or ``start`` mission over a lat/lon
map, and a ``start`` mission over any map, are split at preflight only (``check`` says so).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

from helixd.base.frames import MissionFrame, NedPose
from helixd.base.media import MediaFrame, MediaMap, Medium
from helixd.base.plan import MissionFrameKind, Plan
from helixd.config.root import HelixdConfig
from helixd.files.media import MediaMapError, read_media_map
from helixd.files.models import ConfigFileError
from helixd.mission.model import Mission
from helixd.planning.media_modes import (
    MediaPlan,
    ModePolicy,
    follow_media,
)
from helixd.prepare.ground_learning import learned_plan, learned_policy_modes


class MediaRefused(ValueError):
    """The media map cannot be used; ``problems``: one line each."""

    def __init__(self, problems: list[str]) -> None:
        self.problems = problems
        super().__init__("\n".join(problems))


def with_absolute_media(msn: Mission, mission_path: Path) -> Mission:
    """``msn`` with its ``media_map`` made absolute against its own file's folder."""
    if msn.media_map is None or msn.media_map.is_absolute():
        return msn
    return msn.model_copy(update={"media_map": (mission_path.parent / msn.media_map).resolve()})


def media_path(cfg: HelixdConfig, msn: Mission) -> Path | None:
    """The flight's media map file: the mission's, else the config's, else None."""
    return msn.media_map if msn.media_map is not None else cfg.media.media_map


def read_media(cfg: HelixdConfig, msn: Mission) -> MediaMap | None:
    """The flight's media map, read and checked (None: no map). Raises :class:`MediaRefused`."""
    path = media_path(cfg, msn)
    if path is None:
        return None
    field = "media_map" if msn.media_map is not None else "media.media_map (config)"
    if not path.is_file():
        raise MediaRefused([f"{field}: {path}: no such file"])
    try:
        return read_media_map(path)
    except MediaMapError as exc:
        raise MediaRefused([f"{field}: {p}" for p in exc.problems]) from None


def mode_policy(cfg: HelixdConfig, msn: Mission) -> ModePolicy:
    """The mode per medium: the config's ``media.modes`` (``learned``: the ground profile's
    best, :mod:`helixd.prepare.ground_learning`), the mission's ``media_modes`` over them; the
    margin from ``media.transition_margin_m``. A profile that cannot be read is refused
    (:class:`MediaRefused`)."""
    learned = None
    if isinstance(cfg.media.modes, str):
        try:
            learned = learned_policy_modes(cfg)
        except ConfigFileError as exc:
            raise MediaRefused([f"media.modes learned: {p}" for p in exc.problems]) from None
    return ModePolicy.from_config(cfg.media, msn.media_modes, learned)


@dataclass(frozen=True)
class MediaCheck:
    """What ``check`` can say: the plan split (None: not before preflight, ``why``)."""

    media: MediaPlan | None
    why: str = ""


def check_media_plan(cfg: HelixdConfig, msn: Mission, plan: Plan, media: MediaMap) -> MediaCheck:
    """The plan ``check`` shows split by the media map, where it can be placed without the
    rover: a global mission over any map (origin: waypoint 1, as ``check`` places the
    mission), a local_ned mission over a local_ned map."""
    kind = plan.frame
    if kind is MissionFrameKind.START:
        return MediaCheck(None, "a start-frame mission is placed on the map where it starts")
    if kind is MissionFrameKind.GLOBAL:
        origin: tuple[float, float] | None = msn.points()[0]
    elif media.frame is MediaFrame.LOCAL_NED:
        origin = None
    else:
        return MediaCheck(None, "a lat/lon map under a local_ned mission needs the EKF origin")
    start = plan.assumed_start_xy_m()
    policy = mode_policy(cfg, msn)
    return MediaCheck(split_by_media(plan, media, policy, origin, MissionFrame.enu(), start, cfg))


def split_by_media(
    plan: Plan,
    media: MediaMap,
    policy: ModePolicy,
    origin: tuple[float, float] | None,
    frame: MissionFrame,
    start_xy_m: tuple[float, float],
    cfg: HelixdConfig | None = None,
) -> MediaPlan:
    """``plan`` split by ``media`` placed around ``origin`` (lat, lon; needed for a lat/lon
    map), the mission frame placed by ``frame``; with ``cfg`` under ``media.modes: learned``
    each leg carries the ground the rover learnt (for the estimate). Raises
    :class:`MediaRefused`."""
    try:
        placed = media.to_ne(origin, fallback=Medium.HARD)
    except ValueError as exc:
        raise MediaRefused([str(exc)]) from None
    got = follow_media(plan, placed, policy, start_xy_m, frame.to_ned)
    if cfg is None:
        return got
    try:
        learnt = learned_plan(cfg, got.plan, placed, frame.to_ned, start_xy_m)
    except ConfigFileError as exc:
        raise MediaRefused([f"media.modes learned: {p}" for p in exc.problems]) from None
    return replace(got, plan=learnt)


def placed_media_plan(
    cfg: HelixdConfig,
    msn: Mission,
    plan: Plan,
    origin: tuple[float, float] | None,
    start: NedPose,
) -> MediaPlan | None:
    """At preflight: the plan split by the flight's media map, placed with the EKF origin and
    the rover's start (None: no map). Raises :class:`MediaRefused`."""
    media = read_media(cfg, msn)
    if media is None:
        return None
    frame = (
        MissionFrame.start_at(start) if plan.frame is MissionFrameKind.START else MissionFrame.enu()
    )
    here = frame.to_mission(start)
    first = plan.leg_start_xy_m or (here.x_m, here.y_m)
    return split_by_media(plan, media, mode_policy(cfg, msn), origin, frame, first, cfg)


__all__ = [
    "MediaCheck",
    "MediaRefused",
    "check_media_plan",
    "media_path",
    "mode_policy",
    "placed_media_plan",
    "read_media",
    "split_by_media",
    "with_absolute_media",
]
