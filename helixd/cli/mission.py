"""``helixd mission convert|survey|download|upload``: ground-station files, surveys, and the
autopilot's stored mission over the MAVLink mission protocol.

Registered on the ``mission`` group by :func:`register` (in :mod:`helixd.cli.app`).
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Annotated, TypeVar

import typer

from helixd.base.exitcodes import ExitCode
from helixd.base.plan import MissionFrameKind, MotionMode
from helixd.cli.common import (
    ConfigOpt,
    ModeOpt,
    ObserverConnectOpt,
    config_or_exit,
    fail,
    link_inputs,
    run_on_link,
)
from helixd.commands.placement import place_on_autopilot
from helixd.commands.survey_mission import SurveyRefused, survey_lines, survey_mission
from helixd.files.models import ConfigFileError
from helixd.files.yamlio import clip_line
from helixd.link.connection import Autopilot
from helixd.link.services.mission_link import Downloaded
from helixd.mission.commands import command_name
from helixd.mission.formats import (
    MissionFormat,
    detect_format,
    load_mission_file,
    lost_in,
    read_gcs,
    rebased_media_map,
    sniff_format,
    source_home,
    write_mission_file,
)
from helixd.mission.formats.areas import read_area
from helixd.mission.formats.items import (
    FormatError,
    GcsMission,
    items_to_mission,
    mission_name,
    mission_to_items,
)
from helixd.mission.formats.qgc_plan import plan_to_text
from helixd.mission.formats.wire import WireMission, gcs_to_wire, wire_to_gcs
from helixd.mission.formats.wpl import wpl_to_text
from helixd.mission.placed import PlacementError, parse_latlon, placed_with

T = TypeVar("T")


MissionFileArg = Annotated[Path, typer.Argument(help="mission file: .yaml, .plan or .waypoints")]
OriginOpt = Annotated[
    str | None,
    typer.Option(
        "--origin",
        help="LAT,LON of the EKF origin, to place a local_ned mission (or where the rover "
        "starts, for a start mission) in lat/lon; a run records it in summary.json",
    ),
]
HeadingOpt = Annotated[
    float | None,
    typer.Option(
        "--start-heading-deg",
        min=-360.0,
        max=360.0,
        help="with --origin, a start mission's compass heading at its start (deg)",
    ),
]


def _origin(text: str | None) -> tuple[float, float] | None:
    """``--origin``, checked once at the edge (exit 2 naming it)."""
    if text is None:
        return None
    try:
        return parse_latlon(text)
    except ValueError as exc:
        raise fail([f"--origin {exc}"]) from None


def convert(
    src: MissionFileArg,
    dst: Annotated[Path, typer.Argument(help="output; its suffix names the format")],
    mode: ModeOpt = None,
    config: ConfigOpt = None,
    origin: OriginOpt = None,
    start_heading_deg: HeadingOpt = None,
) -> None:
    """Convert a mission between helixd YAML, QGroundControl .plan and WPL 110 .waypoints."""
    cfg = config_or_exit(config)
    where = _origin(origin)
    gs_mode = cfg.mission.ground_station_mode
    default_mode = MotionMode(gs_mode) if gs_mode else None
    try:
        target = detect_format(dst)
    except FormatError as exc:
        raise fail(exc.problems) from None
    # ground station → ground station: neither file has a place for a mode, so none is needed
    gcs_only = target is not MissionFormat.YAML and sniff_format(src) is not MissionFormat.YAML
    if gcs_only and mode is None and default_mode is None:
        default_mode = MotionMode.ROLL  # a placeholder the output drops
    try:
        loaded = load_mission_file(src, cfg.mission, mode=mode, default_mode=default_mode)
    except ConfigFileError as exc:
        raise fail(exc.problems) from None
    for line in loaded.notes:
        typer.echo(f"warning: {clip_line(line)}", err=True)
    msn = rebased_media_map(loaded.mission, src, dst)
    try:
        if target is not MissionFormat.YAML:  # a ground station needs lat/lon
            msn = placed_with(msn, where, start_heading_deg)
        for what in lost_in(msn, target, had_mode=loaded.format is MissionFormat.YAML):
            typer.echo(f"warning: {dst}: the format has no place for {what}; left out", err=True)
        fmt = write_mission_file(msn, dst, source_home(loaded.gcs))
    except FormatError as exc:
        raise fail(exc.problems) from None
    except PlacementError as exc:
        raise fail([f"{src}: {exc}"]) from None
    except OSError as exc:
        raise fail([f"{dst}: cannot write: {exc.strerror or exc}"]) from None
    n = len(loaded.mission.waypoints)
    typer.echo(f"{src} ({loaded.format.value}) → {dst} ({fmt.value}): {n} items")


SpacingOpt = Annotated[
    float, typer.Option("--spacing-m", min=0.5, max=100.0, help="transect spacing (m)")
]
AngleOpt = Annotated[
    float,
    typer.Option("--angle-deg", min=-360.0, max=360.0, help="transect direction, compass degrees"),
]
MarginOpt = Annotated[
    float,
    typer.Option(
        "--margin-m",
        min=0.0,
        max=100.0,
        help="geofence = the polygon grown by this (m); the rover must start inside it "
        "(run refuses a start outside the fence), so grow this to start farther out",
    ),
]
InsetOpt = Annotated[
    float | None,
    typer.Option(
        "--inset-m",
        min=0.0,
        max=100.0,
        help="keep the rover this far inside the edges (shoreline) and holes (m; default: "
        "the rover's half-width from the vehicle config; off holes at least the planner's "
        "clearance)",
    ),
]
TimeFactorOpt = Annotated[
    float,
    typer.Option(
        "--time-factor",
        min=1.0,
        max=5.0,
        help="mission time limit = this x (estimated time + the longest approach "
        "preflight allows) (slip, pauses)",
    ),
]


def survey(
    polygon: Annotated[
        Path, typer.Argument(help="area: .plan (Survey or geofence polygon), .geojson or .kml")
    ],
    out: Annotated[Path, typer.Option("-o", "--out", help="mission to write (.yaml/.plan/...)")],
    mode: Annotated[MotionMode, typer.Option("--mode", help="motion mode of the mission")],
    spacing_m: SpacingOpt = 10.0,
    angle_deg: AngleOpt = 0.0,
    margin_m: MarginOpt = 2.0,
    inset_m: InsetOpt = None,
    time_factor: TimeFactorOpt = 1.5,
    config: ConfigOpt = None,
) -> None:
    """Boustrophedon survey of a polygon (holes cut out and kept out), with its own geofence
    (the polygon grown by --margin-m: the rover must start inside it), keep-out areas and time
    limit."""
    cfg = config_or_exit(config)
    try:
        got = survey_mission(
            read_area(polygon),
            cfg,
            mission_name(out.stem),
            mode,
            spacing_m=spacing_m,
            angle_deg=angle_deg,
            margin_m=margin_m,
            inset_m=inset_m,
            time_factor=time_factor,
        )
    except FormatError as exc:
        raise fail(exc.problems) from None
    except SurveyRefused as exc:
        raise fail([str(exc)]) from None
    msn, result = got.mission, got.result
    try:
        for what in lost_in(msn, detect_format(out)):
            typer.echo(f"warning: {out}: the format has no place for {what}; left out", err=True)
        write_mission_file(msn, out)
    except FormatError as exc:
        raise fail(exc.problems) from None
    except OSError as exc:
        raise fail([f"{out}: cannot write: {exc.strerror or exc}"]) from None
    for line in survey_lines(got, polygon, out, angle_deg, margin_m):
        typer.echo(line)
    typer.echo(f"coverage: {result.coverage * 100:.1f} % of the area within {spacing_m / 2:g} m")
    if result.coverage < MIN_COVERAGE:
        typer.echo(
            f"warning: coverage below {MIN_COVERAGE * 100:.0f} %: use a smaller --spacing-m or "
            "another --angle-deg",
            err=True,
        )


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(path)


def describe_gcs(gcs: GcsMission) -> list[str]:
    """Stdout summary of what the autopilot holds (pure)."""
    home = gcs.home_latlon_deg
    lines = [f"home    : {home[0]:.7f}, {home[1]:.7f}" if home else "home    : not set"]
    counts = Counter(command_name(it.command) for it in gcs.items)
    kinds = ", ".join(f"{n} {name}" for name, n in counts.most_common()) or "none"
    lines.append(f"mission : {len(gcs.items)} items ({kinds})")
    for it in gcs.items:
        lines.append(
            f"  {it.seq:4d} {command_name(it.command):22s} frame {it.frame:2d}  "
            f"x {it.x:.7f}  y {it.y:.7f}  z {it.z:g}"
        )
    inc = sum(p.inclusion for p in gcs.polygons) + sum(c.inclusion for c in gcs.circles)
    exc = len(gcs.polygons) + len(gcs.circles) - inc
    lines.append(
        f"fence   : {len(gcs.polygons)} polygons, {len(gcs.circles)} circles "
        f"({inc} inclusion, {exc} exclusion)"
    )
    return lines


def download(
    out: Annotated[
        Path | None,
        typer.Argument(help="write to .plan, .waypoints or .yaml; summary on stdout if omitted"),
    ] = None,
    connect: ObserverConnectOpt = None,
    mode: ModeOpt = None,
    config: ConfigOpt = None,
) -> None:
    """Read the autopilot's stored mission and fence over MAVLink (MISSION_ITEM_INT)."""
    fmt = None
    if out is not None:
        try:
            fmt = detect_format(out)
        except FormatError as exc:
            raise fail(exc.problems) from None
    cfg, link = link_inputs(config, connect)
    gs_mode = mode or (
        MotionMode(cfg.mission.ground_station_mode) if cfg.mission.ground_station_mode else None
    )
    if fmt is MissionFormat.YAML and gs_mode is None:
        raise fail(
            [f"{out}: a helixd mission needs a motion mode: give --mode roll|scroll|omni or set "
             "mission.ground_station_mode in the config"]
        )  # fmt: skip

    async def body(ap: Autopilot) -> Downloaded:
        return await ap.mission.download()

    got = run_on_link(cfg, link, body)
    try:
        gcs, notes = wire_to_gcs(got.mission, got.fence)
    except FormatError as exc:
        raise fail([f"{link.url}: {p}" for p in exc.problems], ExitCode.PREFLIGHT) from None
    for note in notes:
        typer.echo(f"warning: {clip_line(note)}", err=True)
    if out is None or fmt is None:
        for line in describe_gcs(gcs):
            typer.echo(line)
        return
    try:
        if fmt is MissionFormat.PLAN:
            _write_atomic(out, plan_to_text(gcs))
        elif fmt is MissionFormat.WAYPOINTS:
            if gcs.polygons or gcs.circles:
                typer.echo(f"warning: {out}: the format has no place for the fence; left out",
                           err=True)  # fmt: skip
            _write_atomic(out, wpl_to_text(gcs))
        else:
            assert gs_mode is not None
            conv = items_to_mission(
                gcs,
                name=mission_name(out.stem),
                mode=gs_mode,
                source=link.url,
            )
            for line in conv.notes:
                typer.echo(f"warning: {clip_line(line)}", err=True)
            write_mission_file(conv.mission, out)
    except FormatError as exc:
        raise fail(exc.problems) from None
    except OSError as exc:
        raise fail([f"{out}: cannot write: {exc.strerror or exc}"]) from None
    fence = len(gcs.polygons) + len(gcs.circles)
    typer.echo(
        f"{link.url} → {out} ({fmt.value}): {len(gcs.items)} mission items, {fence} fence shapes "
        f"(as system {link.observer_system})"
    )


def upload(
    src: MissionFileArg,
    connect: ObserverConnectOpt = None,
    config: ConfigOpt = None,
    origin: OriginOpt = None,
    start_heading_deg: HeadingOpt = None,
) -> None:
    """Write a mission (and a .plan's geofence) to the autopilot over MAVLink, as QGC does.

    A .plan also replaces the autopilot's fence (empty if the plan has none).

    A .waypoints or helixd .yaml file leaves the fence as it is. A local_ned (or start)
    mission is placed in lat/lon through --origin, else through the autopilot's own EKF
    origin (a start mission: at the rover's pose now)."""
    cfg, link = link_inputs(config, connect)
    where = _origin(origin)
    fmt = sniff_format(src)
    msn = None
    try:
        if fmt is MissionFormat.YAML:
            msn = load_mission_file(src, cfg.mission).mission
            if where is not None:
                msn = placed_with(msn, where, start_heading_deg)
            gcs = None if msn.frame is not MissionFrameKind.GLOBAL else mission_to_items(msn)
        else:
            gcs = read_gcs(src)
        wire = None if gcs is None else gcs_to_wire(gcs)
    except ConfigFileError as exc:
        raise fail(exc.problems) from None
    except PlacementError as exc:
        raise fail([f"{src}: {exc}"]) from None
    except FormatError as exc:
        raise fail([p if p.startswith(str(src)) else f"{src}: {p}" for p in exc.problems]) from None

    async def body(ap: Autopilot) -> WireMission:
        if ap.state.armed:
            typer.echo(
                f"warning: the autopilot is armed (mode {ap.state.mode}): in AUTO it follows "
                "the new mission at once",
                err=True,
            )
        got = wire
        if got is None:  # place it through the autopilot's EKF origin (and the rover's pose)
            assert msn is not None
            got = await place_on_autopilot(ap, msn, cfg.link.command_timeout_s * 3)
            typer.echo(f"{src}: placed through the autopilot's EKF origin", err=True)
        await ap.mission.upload(got.mission, got.fence if fmt is MissionFormat.PLAN else None)
        return got

    try:
        wire = run_on_link(cfg, link, body)
    except PlacementError as exc:
        raise fail([f"{src}: {exc}"], ExitCode.PREFLIGHT) from None
    fence = wire.fence if fmt is MissionFormat.PLAN else None
    what = f"{len(wire.mission) - 1} mission items (+ home)"
    if fence is not None:
        what += f" and {len(fence)} fence items"
    typer.echo(f"{src} → {link.url}: {what} accepted (as system {link.observer_system})")


MIN_COVERAGE = 0.95  # below this, the operator is told (the survey is still written)


def register(app: typer.Typer) -> None:
    """Add ``convert``, ``survey``, ``download`` and ``upload`` to ``app`` (the mission group)."""
    app.command("convert")(convert)
    app.command("survey")(survey)
    app.command("download")(download)
    app.command("upload")(upload)
