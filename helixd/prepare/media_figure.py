"""What ``helixd check --plot`` draws of a media map: the map placed as ``check`` places the
mission (a global mission around waypoint 1, a local_ned one over a local_ned map) and the
plan split by it, each stretch in its mode
(:func:`helixd.recorder.plan_plots.render_media_plan`)."""

from __future__ import annotations

from dataclasses import dataclass

from helixd.base.frames import MissionFrame
from helixd.base.media import MediaMap, Medium
from helixd.base.plan import MissionFrameKind
from helixd.config.root import HelixdConfig
from helixd.mission.expand import DEFAULT_OPTIONS, ExpandOptions
from helixd.mission.model import Mission
from helixd.mission.validate import plan_for_check
from helixd.planning.media_modes import MediaPlan
from helixd.prepare.media import MediaRefused, check_media_plan
from helixd.recorder.media_plot import PlacedMedia

__all__ = ["CheckedMedia", "checked_media"]


@dataclass(frozen=True)
class CheckedMedia:
    """The map and the plan ``check`` shows: placed (None with ``why`` when ``check`` cannot
    place them before preflight)."""

    placed: PlacedMedia | None
    plan: MediaPlan | None
    why: str = ""


def checked_media(
    cfg: HelixdConfig,
    msn: Mission,
    planned: Mission,
    media: MediaMap,
    options: ExpandOptions = DEFAULT_OPTIONS,
) -> CheckedMedia:
    """``media`` placed and ``planned`` split by it, as ``check``'s lines show them."""
    plan, _ = plan_for_check(planned, cfg, options)
    try:
        followed = check_media_plan(cfg, msn, plan, media)
    except MediaRefused as exc:
        return CheckedMedia(None, None, "; ".join(exc.problems))
    if followed.media is None:
        return CheckedMedia(None, None, followed.why)
    origin = msn.points()[0] if plan.frame is MissionFrameKind.GLOBAL else None
    try:
        placed = media.to_ne(origin, fallback=Medium.HARD)
    except ValueError as exc:
        return CheckedMedia(None, None, str(exc))
    return CheckedMedia(PlacedMedia(placed, MissionFrame.enu()), followed.media)
