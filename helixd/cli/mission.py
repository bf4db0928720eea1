"""``helixd mission convert|survey|download|upload`` and ``helixd export``: ground-station
files, surveys, and the autopilot's stored mission over the MAVLink mission protocol.

Registered on the main app by :func:`register` (one line in :mod:`helixd.cli.app`).
"""

from __future__ import annotations

import math
from collections import Counter
from pathlib import Path
from typing import Annotated, TypeVar

import typer

from helixd.base.exitcodes import ExitCode
from helixd.cli.common import config_or_exit, fail, link_inputs, run_on_link
from helixd.files.models import ConfigFileError
from helixd.files.yamlio import clip_line
from helixd.link.connection import Autopilot
from helixd.link.mission_link import Downloaded, autopilot_sender, download_all, upload_all
from helixd.mission.commands import command_name
from helixd.mission.formats import (
    FormatError,
    GcsMission,
    MissionFormat,
    detect_format,
    items_to_mission,
    load_mission_file,
    lost_in,
    mission_to_items,
    read_gcs,
    sniff_format,
    write_mission_file,
)
from helixd.mission.formats.areas import read_area
from helixd.mission.formats.items import mission_name
from helixd.mission.formats.qgc_plan import plan_to_text
from helixd.mission.formats.wire import gcs_to_wire, wire_to_gcs
from helixd.mission.formats.wpl import wpl_to_text
from helixd.mission.model import Mission, MotionMode
from helixd.mission.plan import resolve_plan
from helixd.mission.survey import SurveyError, plan_survey
from helixd.recorder import export

T = TypeVar("T")

mission_app = typer.Typer(
    name="mission",
    help="Mission files: convert between helixd YAML, QGroundControl .plan and .waypoints; "
    "generate surveys.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


ModeOpt = Annotated[
    MotionMode | None,
    typer.Option("--mode", help="motion mode (needed when reading .plan/.waypoints)"),
]


@mission_app.command("convert")
def convert(
    src: Annotated[Path, typer.Argument(help="mission file: .yaml, .plan or .waypoints")],
    dst: Annotated[Path, typer.Argument(help="output; its suffix names the format")],
    mode: ModeOpt = None,
    config: Annotated[
        Path | None, typer.Option("--config", "-c", help="helixd.yaml (mission limits, mode)")
    ] = None,
) -> None:
    """Convert a mission between helixd YAML, QGroundControl .plan and WPL 110 .waypoints."""
    cfg = config_or_exit(config)
    gs_mode = cfg.mission.ground_station_mode
    try:
        loaded = load_mission_file(
            src,
            cfg.mission,
            mode=mode,
            default_mode=MotionMode(gs_mode) if gs_mode else None,
        )
    except ConfigFileError as exc:
        raise fail(exc.problems) from None
    for line in loaded.notes:
        typer.echo(f"warning: {clip_line(line)}", err=True)
    try:
        for what in lost_in(loaded.mission, detect_format(dst)):
            typer.echo(f"warning: {dst}: the format has no place for {what}; left out", err=True)
        fmt = write_mission_file(loaded.mission, dst)
    except FormatError as exc:
        raise fail(exc.problems) from None
    except OSError as exc:
        raise fail([f"{dst}: cannot write: {exc.strerror or exc}"]) from None
    n = len(loaded.mission.waypoints)
    typer.echo(f"{src} ({loaded.format.value}) → {dst} ({fmt.value}): {n} items")


@mission_app.command("survey")
def survey(
    polygon: Annotated[
        Path, typer.Argument(help="area: .plan (Survey or geofence polygon), .geojson or .kml")
    ],
    out: Annotated[Path, typer.Option("-o", "--out", help="mission to write (.yaml/.plan/...)")],
    mode: Annotated[MotionMode, typer.Option("--mode", help="motion mode of the mission")],
    spacing_m: Annotated[
        float, typer.Option("--spacing-m", min=0.5, max=100.0, help="transect spacing (m)")
    ] = 10.0,
    angle_deg: Annotated[
        float,
        typer.Option(
            "--angle-deg", min=-360.0, max=360.0, help="transect direction, compass degrees"
        ),
    ] = 0.0,
    margin_m: Annotated[
        float,
        typer.Option(
            "--margin-m", min=0.0, max=100.0, help="geofence = the polygon grown by this (m)"
        ),
    ] = 2.0,
    inset_m: Annotated[
        float,
        typer.Option(
            "--inset-m",
            min=0.0,
            max=100.0,
            help="keep the rover this far inside the edges and holes (shoreline, keep-outs) (m)",
        ),
    ] = 0.0,
    time_factor: Annotated[
        float,
        typer.Option(
            "--time-factor",
            min=1.0,
            max=5.0,
            help="mission time limit = estimated time x this (slip, turns, pauses)",
        ),
    ] = 1.5,
    config: Annotated[
        Path | None, typer.Option("--config", "-c", help="helixd.yaml (speed, yaw rate)")
    ] = None,
) -> None:
    """Boustrophedon survey of a polygon (holes cut out), with its own geofence and time limit."""
    cfg = config_or_exit(config)
    try:
        area = read_area(polygon)
        result = plan_survey(
            area, spacing_m=spacing_m, angle_deg=angle_deg, margin_m=margin_m, inset_m=inset_m
        )
    except FormatError as exc:
        raise fail(exc.problems) from None
    except SurveyError as exc:
        raise fail([str(exc)]) from None
    if len(result.fence_latlon_deg) > 1000:
        raise fail([f"{polygon}: the fence has {len(result.fence_latlon_deg)} vertices (> 1000)"])
    data: dict[str, object] = {
        "name": mission_name(out.stem),
        "mode": mode.value,
        "frame": "global",
        "waypoints": [{"lat": a, "lon": b} for a, b in result.waypoints_latlon_deg],
        "geofence_polygon": [list(v) for v in result.fence_latlon_deg],
    }
    try:
        msn = Mission.model_validate(data, context={"limits": cfg.mission})
        plan = resolve_plan(msn, cfg.control, cfg.mission, result.waypoints_latlon_deg[0])
    except Exception as exc:  # pydantic ValidationError / PlanError: say it, no traceback
        raise fail([f"{polygon}: the survey is not a valid mission: {exc}"]) from None
    first = plan.waypoints[0]
    eta_s = plan.estimated_time_s(cfg.control.max_yaw_rate_radps, (first.x_m, first.y_m))
    limit_s = math.ceil(eta_s * time_factor)
    if limit_s > 86_400:
        raise fail(
            [
                f"{polygon}: estimated {eta_s / 3600:.1f} h x {time_factor} exceeds 24 h; split "
                "the area"
            ]
        )
    msn = msn.model_copy(update={"time_limit_s": float(limit_s)})
    try:
        for what in lost_in(msn, detect_format(out)):
            typer.echo(f"warning: {out}: the format has no place for {what}; left out", err=True)
        write_mission_file(msn, out)
    except FormatError as exc:
        raise fail(exc.problems) from None
    except OSError as exc:
        raise fail([f"{out}: cannot write: {exc.strerror or exc}"]) from None
    typer.echo(
        f"survey  : {polygon} → {out}  area {result.area_m2:.0f} m², {result.transects} "
        f"transects at {spacing_m:g} m, angle {angle_deg:g}°"
    )
    typer.echo(
        f"path    : {result.path_length_m:.0f} m, {len(msn.waypoints)} waypoints, estimated "
        f"{eta_s / 3600:.2f} h at {plan.speed_mps:.2f} m/s; time limit {limit_s} s"
    )
    typer.echo(
        f"fence   : the polygon grown by {margin_m:g} m ({len(msn.geofence_polygon)} vertices)"
    )
    typer.echo(f"coverage: {result.coverage * 100:.1f} % of the area within {spacing_m / 2:g} m")
    if result.coverage < MIN_COVERAGE:
        typer.echo(
            f"warning: coverage below {MIN_COVERAGE * 100:.0f} %: use a smaller --spacing-m or "
            "another --angle-deg",
            err=True,
        )


ConnectOpt = Annotated[
    str | None, typer.Option("--connect", help="autopilot link (default: link.url)")
]
ConfigOpt = Annotated[Path | None, typer.Option("--config", "-c", help="helixd.yaml")]


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


@mission_app.command("download")
def download(
    out: Annotated[
        Path | None,
        typer.Argument(help="write to .plan, .waypoints or .yaml; summary on stdout if omitted"),
    ] = None,
    connect: ConnectOpt = None,
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
        return await download_all(ap, autopilot_sender(ap))

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
        f"{link.url} → {out} ({fmt.value}): {len(gcs.items)} mission items, {fence} fence shapes"
    )


@mission_app.command("upload")
def upload(
    src: Annotated[Path, typer.Argument(help="mission file: .plan, .waypoints or .yaml")],
    connect: ConnectOpt = None,
    config: ConfigOpt = None,
) -> None:
    """Write a mission (and a .plan's geofence) to the autopilot over MAVLink, as QGC does.

    A .plan also replaces the autopilot's fence (empty if the plan has none).

    A .waypoints or helixd .yaml file leaves the fence as it is."""
    cfg, link = link_inputs(config, connect)
    fmt = sniff_format(src)
    try:
        if fmt is MissionFormat.YAML:
            gcs = mission_to_items(load_mission_file(src, cfg.mission).mission)
        else:
            gcs = read_gcs(src)
        wire = gcs_to_wire(gcs)
    except ConfigFileError as exc:
        raise fail(exc.problems) from None
    except FormatError as exc:
        raise fail([p if p.startswith(str(src)) else f"{src}: {p}" for p in exc.problems]) from None
    fence = wire.fence if fmt is MissionFormat.PLAN else None

    async def body(ap: Autopilot) -> None:
        if ap.state.armed:
            typer.echo(
                f"warning: the autopilot is armed (mode {ap.state.mode}): in AUTO it follows "
                "the new mission at once",
                err=True,
            )
        await upload_all(ap, autopilot_sender(ap), wire.mission, fence)

    run_on_link(cfg, link, body)
    what = f"{len(wire.mission) - 1} mission items (+ home)"
    if fence is not None:
        what += f" and {len(fence)} fence items"
    typer.echo(f"{src} → {link.url}: {what} accepted")


MIN_COVERAGE = 0.95  # below this, the operator is told (the survey is still written)


def register(app: typer.Typer) -> None:
    app.add_typer(mission_app, name="mission")
    export.register(app)
