"""``helixd mission convert|survey`` and ``helixd export``: ground-station files and surveys.

Registered on the main app by :func:`register` (one line in :mod:`helixd.cli`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import typer

from helixd.config import ConfigFileError, load_config
from helixd.exitcodes import ExitCode
from helixd.mission.formats import (
    FormatError,
    detect_format,
    load_mission_file,
    lost_in,
    write_mission_file,
)
from helixd.mission.model import MotionMode
from helixd.yamlio import clip_line

mission_app = typer.Typer(
    name="mission",
    help="Mission files: convert between helixd YAML, QGroundControl .plan and .waypoints; "
    "generate surveys.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def _fail(problems: list[str], code: ExitCode = ExitCode.USAGE) -> typer.Exit:
    for line in problems:
        typer.echo(f"error: {clip_line(line)}", err=True)
    return typer.Exit(int(code))


ModeOpt = Annotated[
    MotionMode | None,
    typer.Option("--mode", help="motion mode (needed when reading .plan/.waypoints)"),
]


@mission_app.command("convert")
def convert(
    src: Annotated[Path, typer.Argument(help="mission file: .yaml, .plan or .waypoints")],
    dst: Annotated[Path, typer.Argument(help="output; its suffix names the format")],
    mode: ModeOpt = None,
    skip_unsupported: Annotated[
        bool, typer.Option("--skip-unsupported", help="leave out items helixd cannot fly")
    ] = False,
    config: Annotated[
        Path | None, typer.Option("--config", "-c", help="helixd.yaml (mission limits, mode)")
    ] = None,
) -> None:
    """Convert a mission between helixd YAML, QGroundControl .plan and WPL 110 .waypoints."""
    try:
        cfg = load_config(config)
    except ConfigFileError as exc:
        raise _fail(exc.problems) from None
    gs_mode = cfg.mission.ground_station_mode
    try:
        loaded = load_mission_file(
            src,
            cfg.mission,
            mode=mode,
            default_mode=MotionMode(gs_mode) if gs_mode else None,
            skip_unsupported=skip_unsupported,
        )
    except ConfigFileError as exc:
        raise _fail(exc.problems) from None
    for line in (*loaded.skipped, *loaded.notes):
        typer.echo(f"warning: {clip_line(line)}", err=True)
    try:
        for what in lost_in(loaded.mission, detect_format(dst)):
            typer.echo(f"warning: {dst}: the format has no place for {what}; left out", err=True)
        fmt = write_mission_file(loaded.mission, dst)
    except FormatError as exc:
        raise _fail(exc.problems) from None
    except OSError as exc:
        raise _fail([f"{dst}: cannot write: {exc.strerror or exc}"]) from None
    n = len(loaded.mission.waypoints)
    typer.echo(f"{src} ({loaded.format.value}) → {dst} ({fmt.value}): {n} waypoints")


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
    from helixd.mission.formats.areas import read_area
    from helixd.mission.formats.items import mission_name
    from helixd.mission.model import Mission
    from helixd.mission.plan import resolve_plan
    from helixd.mission.survey import SurveyError, plan_survey

    try:
        cfg = load_config(config)
    except ConfigFileError as exc:
        raise _fail(exc.problems) from None
    try:
        area = read_area(polygon)
        result = plan_survey(
            area, spacing_m=spacing_m, angle_deg=angle_deg, margin_m=margin_m, inset_m=inset_m
        )
    except FormatError as exc:
        raise _fail(exc.problems) from None
    except SurveyError as exc:
        raise _fail([str(exc)]) from None
    if len(result.fence_latlon_deg) > 1000:
        raise _fail([f"{polygon}: the fence has {len(result.fence_latlon_deg)} vertices (> 1000)"])
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
        raise _fail([f"{polygon}: the survey is not a valid mission: {exc}"]) from None
    first = plan.waypoints[0]
    eta_s = plan.estimated_time_s(cfg.control.max_yaw_rate_radps, (first.x_m, first.y_m))
    limit_s = math.ceil(eta_s * time_factor)
    if limit_s > 86_400:
        raise _fail(
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
        raise _fail(exc.problems) from None
    except OSError as exc:
        raise _fail([f"{out}: cannot write: {exc.strerror or exc}"]) from None
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


MIN_COVERAGE = 0.95  # below this, the operator is told (the survey is still written)


def register(app: typer.Typer) -> None:
    from helixd import export

    app.add_typer(mission_app, name="mission")
    export.register(app)
