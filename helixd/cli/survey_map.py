"""``helixd survey-map``: parse, call :mod:`helixd.commands.survey_map`, print."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from helixd.base.exitcodes import ExitCode
from helixd.base.plan import MotionMode
from helixd.cli.common import fail
from helixd.files.media import MediaMapError, read_media_map
from helixd.mission.formats.areas import read_area
from helixd.mission.formats.items import FormatError


def survey_map(
    runs: Annotated[
        list[Path], typer.Argument(help="run directories (or payload.csv files) to grid together")
    ],
    out: Annotated[
        Path | None,
        typer.Option("-o", "--out", help="output directory (default: <first run>/survey-map)"),
    ] = None,
    area: Annotated[
        Path | None,
        typer.Option(
            "--area",
            help="the surveyed area (.geojson, .kml or .plan polygon): its cells without a "
            "reading are the holes; default: the readings' convex hull",
        ),
    ] = None,
    cell_m: Annotated[
        float, typer.Option("--cell-m", min=0.1, max=100.0, help="grid cell size (m)")
    ] = 2.0,
    contour_m: Annotated[
        float, typer.Option("--contour-m", min=0.01, max=100.0, help="contour interval (m)")
    ] = 0.25,
    quantity: Annotated[
        str, typer.Option("--quantity", help="payload.csv quantity to grid")
    ] = "depth_m",
    media: Annotated[
        Path | None, typer.Option("--media", help="media map to draw under the depths")
    ] = None,
    mode: Annotated[
        MotionMode, typer.Option("--mode", help="motion mode of the holes mission")
    ] = MotionMode.SCROLL,
) -> None:
    """Grid the depth readings of survey runs: GeoTIFF, x y z CSV, contours (GeoJSON, PNG),
    per-cell count and spread, and the cells without a reading as a mission (holes.yaml)."""
    # deferred, as `helixd plot`'s: matplotlib (0.2 s) only when a map is made
    from helixd.commands.survey_map import SurveyMapRefused, build_map, write_map

    try:
        surveyed = None if area is None else read_area(area)
        media_map = None if media is None else read_media_map(media)
        m = build_map(runs, cell_m=cell_m, area=surveyed, quantity=quantity)
    except FormatError as exc:
        raise fail(exc.problems, ExitCode.USAGE) from None
    except MediaMapError as exc:
        raise fail([f"--media: {p}" for p in exc.problems], ExitCode.USAGE) from None
    except SurveyMapRefused as exc:
        raise fail(exc.problems, ExitCode.USAGE) from None
    first = runs[0] if runs[0].is_dir() else runs[0].parent
    target = out if out is not None else first / "survey-map"
    try:
        written = write_map(m, target, contour_step_m=contour_m, media=media_map, mode=mode)
    except OSError as exc:
        raise fail([f"{target}: cannot write: {exc.strerror or exc}"]) from None
    f = written.figures
    typer.echo(
        f"readings: {f['samples']} {quantity} in {len(runs)} run(s)"
        + (f", {f['skipped']} without a place" if f["skipped"] else "")
    )
    typer.echo(
        f"grid    : {cell_m:g} m cells, {f['covered_cells']}/{f['area_cells']} of the area "
        f"with data (coverage {float(str(f['coverage'])) * 100:.1f} %), depth "
        f"{f['depth_min_m']}..{f['depth_max_m']} m, median spread {f['spread_median_m']} m"
    )
    typer.echo(
        f"holes   : {f['holes']} cells without a reading"
        + (f" → holes.yaml, {f['holes_mission_items']} waypoints" if f["holes"] else "")
    )
    for path in written.files:
        typer.echo(f"wrote   : {path}")


def register(app: typer.Typer) -> None:
    app.command("survey-map")(survey_map)
