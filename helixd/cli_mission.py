"""``helixd mission convert|survey`` and ``helixd export``: ground-station files and surveys.

Registered on the main app by :func:`register` (one line in :mod:`helixd.cli`).
"""

from __future__ import annotations

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
            mode=mode or (MotionMode(gs_mode) if gs_mode else None),
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


def register(app: typer.Typer) -> None:
    app.add_typer(mission_app, name="mission")
