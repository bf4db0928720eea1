"""``helixd run --mission autopilot``: fly the mission the autopilot holds.

The mission (and fence) are downloaded over the MAVLink mission protocol
(``ap.mission.download()``, :class:`helixd.link.services.mission_link.MissionClient`) in a short
link session on the run's own URL, right before the run connects for flight; the items then go
through the converter every ``.plan`` file goes through
(:func:`helixd.mission.formats.wire.wire_to_gcs` →
:func:`helixd.mission.formats.items.items_to_mission`), with the motion mode from ``--mode`` or
``mission.ground_station_mode``, and from there through the same checks as a mission file.

Refusals exit 3 (PREFLIGHT: the autopilot's mission cannot be flown; nothing was armed), one
line per problem naming the item: an empty mission, an item helixd cannot fly (unless
``--skip-unsupported``), a waypoint out of range. The autopilot's stored fence comes with it:
its inclusion polygon keeps the rover in, its exclusion zones are planned around (a
``--fence`` file adds its shapes).
"""

from __future__ import annotations

from pathlib import Path

import typer

from helixd.base.exitcodes import ExitCode
from helixd.base.plan import MotionMode
from helixd.cli.common import run_on_link
from helixd.config.root import HelixdConfig
from helixd.files.yamlio import MAX_ERROR_LINE_CHARS, clip_line
from helixd.link.connection import Autopilot
from helixd.link.services.mission_link import Downloaded
from helixd.mav.mission_item import MissionItem
from helixd.prepare.autopilot_mission import (
    MISSION_NAME,
    FromAutopilot,
    MissionRefused,
    convert_download,
    ground_station_mode,
)

__all__ = ["AUTOPILOT_MISSION", "fetch_autopilot_mission", "wants_autopilot"]

AUTOPILOT_MISSION = MISSION_NAME


def wants_autopilot(mission: Path) -> bool:
    """``--mission autopilot`` (a file of that name must be given as ``./autopilot``)."""
    return str(mission) == AUTOPILOT_MISSION


def _refuse(problems: list[str]) -> typer.Exit:
    for line in problems:
        typer.echo(f"error: {clip_line(line, MAX_ERROR_LINE_CHARS)}", err=True)
    return typer.Exit(int(ExitCode.PREFLIGHT))


def convert(
    got_mission: tuple[MissionItem, ...],
    got_fence: tuple[MissionItem, ...],
    *,
    source: str,
    cfg: HelixdConfig,
    mode: MotionMode | None,
    fence: Path | None = None,
) -> FromAutopilot:
    """Downloaded items → a validated mission (:func:`convert_download`), its warnings
    printed; a refusal exits 3."""
    gs_mode = motion_mode(cfg, mode)
    try:
        out = convert_download(
            got_mission, got_fence, source=source, cfg=cfg, mode=gs_mode, fence=fence
        )
    except MissionRefused as exc:
        raise _refuse(exc.problems) from None
    for line in out.notes:
        typer.echo(f"warning: {clip_line(line)}", err=True)
    return out


def motion_mode(cfg: HelixdConfig, mode: MotionMode | None) -> MotionMode:
    """``--mode``, else ``mission.ground_station_mode``; neither is a usage error (exit 2)."""
    gs = ground_station_mode(cfg, mode)
    if gs is None:
        typer.echo(
            "error: --mission autopilot carries no motion mode: give --mode roll|scroll|omni "
            "or set mission.ground_station_mode in the config",
            err=True,
        )
        raise typer.Exit(int(ExitCode.USAGE))
    return gs


def fetch_autopilot_mission(
    cfg: HelixdConfig, url: str, mode: MotionMode | None, fence: Path | None = None
) -> FromAutopilot:
    """Download the autopilot's mission and fence at ``url`` and convert them; link failures
    exit 6 (LINK), the autopilot's refusal or an unflyable mission exit 3 (PREFLIGHT)."""
    motion_mode(cfg, mode)  # before any link
    link = cfg.link.model_copy(update={"url": url})

    async def body(ap: Autopilot) -> Downloaded:
        return await ap.mission.download()

    got = run_on_link(cfg, link, body)
    source = f"autopilot at {url}"
    out = convert(
        got.mission,
        got.fence,
        source=source,
        cfg=cfg,
        mode=mode,
        fence=fence,
    )
    typer.echo(
        f"mission : {source}: {out.items} mission items, {out.fence_shapes} fence shapes "
        f"→ {len(out.mission.points())} places ({out.mission.mode.value})",
        err=True,
    )
    return out
