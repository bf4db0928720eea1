"""The media map of a flight and the plan that follows it (the shell around
:mod:`helixd.planning.media_modes`).

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

import os
from dataclasses import dataclass, replace
from pathlib import Path

from helixd.base.frames import MissionFrame, NedPose
from helixd.base.media import MediaFrame, MediaMap, Medium
from helixd.base.plan import MissionFrameKind, MotionMode, Plan
from helixd.config.root import HelixdConfig
from helixd.files.media import MediaMapError, read_media_map
from helixd.files.models import ConfigFileError
from helixd.mission.model import Mission
from helixd.planning.media_modes import (
    MediaPlan,
    ModePolicy,
    follow_media,
    pinned_misfits,
    policy_modes,
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
    if isinstance(cfg.media.modes, str):
        try:
            modes = learned_policy_modes(cfg)
        except ConfigFileError as exc:
            raise MediaRefused([f"media.modes learned: {p}" for p in exc.problems]) from None
    else:
        modes = policy_modes(cfg.media.modes.model_dump())
    modes.update(msn.media_modes or {})
    return ModePolicy(modes, cfg.media.transition_margin_m, cfg.media.min_stretch_m)


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
    return MediaCheck(follow(plan, media, policy, origin, MissionFrame.enu(), start, cfg))


def follow(
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
    return follow(plan, media, mode_policy(cfg, msn), origin, frame, first, cfg)


def stretch_lines(got: MediaPlan) -> list[str]:
    """``check``'s lines: each stretch's medium and mode, each change of mode."""
    lines: list[str] = []
    transitions = iter(got.transitions)
    for k, st in enumerate(got.stretches):
        media = ", ".join(f"{m.value} {length:.1f} m" for m, length in st.media_m if length > 0.05)
        pinned = " (the waypoint's own mode)" if st.pinned else ""
        lines.append(
            f"stretch : {k + 1}  {st.start_m:6.1f} → {st.end_m:6.1f} m  {st.mode.value:<6} "
            f"over {media or st.main_medium.value}{pinned}"
        )
        after = got.stretches[k + 1] if k + 1 < len(got.stretches) else None
        # a change of mode stands between two stretches in different modes only (a pinned
        # stretch and its unpinned neighbour in the same mode have none between them)
        t = next(transitions, None) if after is not None and after.mode is not st.mode else None
        if t is not None:
            turn = "stop, turn 90° in place" if t.turn_rad > 0.0 else "stop, no turn (OMNI)"
            lines.append(
                f"change  : {t.before.value} → {t.after.value} at ({t.xy_m[0]:.1f}, "
                f"{t.xy_m[1]:.1f}) on {t.medium.value}: {turn}"
            )
    return lines


def pinned_warnings(got: MediaPlan, policy: ModePolicy) -> list[str]:
    """``check``'s warning for each leg a waypoint pins to a mode over ground that mode cannot
    move in (the map's modes say another): rolling barely moves in water and mud."""
    lines: list[str] = []
    for k, st, misfit in pinned_misfits(got, policy):
        where = ", ".join(f"{m.value} {length:.1f} m" for m, length in misfit)
        wants = "/".join(dict.fromkeys(policy.mode_for(m).value for m, _ in misfit))
        lines.append(
            f"warning : stretch {k + 1} is pinned to {st.mode.value} by its waypoint's mode "
            f"across {where}, which the map's modes fly in {wants}: {st.mode.value} barely "
            "moves there, the estimate does not count it, and in flight the ground check "
            "changes the mode where the rover bogs down — drop the waypoint's `mode:` to let "
            "the map choose"
        )
    return lines


def shown_path(path: Path | None) -> str:
    """A file as a crew reads it: relative to the working directory (as a mission names its
    map, ``../maps/pond-media.geojson``) unless the absolute path is shorter."""
    if path is None:
        return "(none)"
    try:
        relative = os.path.relpath(path, Path.cwd())
    except ValueError:  # another drive
        return str(path)
    return relative if len(relative) <= len(str(path)) else str(path)


def modes_text(plan: Plan) -> str:
    """``roll``, or ``roll/scroll`` for a plan whose mode follows the medium."""
    seen: list[MotionMode] = []
    for i in range(len(plan.waypoints)):
        m = plan.mode_at(i)
        if m not in seen:
            seen.append(m)
    return "/".join(m.value for m in seen) or plan.mode.value


__all__ = [
    "MediaCheck",
    "MediaRefused",
    "check_media_plan",
    "follow",
    "media_path",
    "mode_policy",
    "modes_text",
    "pinned_warnings",
    "placed_media_plan",
    "read_media",
    "shown_path",
    "stretch_lines",
    "with_absolute_media",
]
