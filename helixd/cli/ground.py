"""``helixd ground``: what the rover has learnt of its ground (the profile), or what given runs
alone say of it (``helixd ground runs/<run> … --media MAP``), the mode ``media.modes:
learned`` picks per medium; the crew pins a fraction or resets the profile."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from helixd.base.exitcodes import ExitCode
from helixd.cli.common import ConfigOpt, config_or_exit, fail
from helixd.commands.ground import (
    GroundCommandError,
    GroundReport,
    driven_samples,
    fraction_text,
    from_runs,
    parse_pin,
    report,
)
from helixd.control.ground_fit import AXES
from helixd.files.media import MediaMapError, read_media_map
from helixd.files.models import ConfigFileError
from helixd.prepare.ground_learning import profile_path
from helixd.recorder.ground_profile import read_profile, write_profile


def _table(rep: GroundReport) -> Table:
    table = Table(title=f"ground: {rep.source}")
    for head in ("medium", "mode", "runs", "samples", "metres", *AXES, "W per m/s"):
        table.add_column(head, justify="left" if head in ("medium", "mode") else "right")
    for row in rep.rows:
        v = row.view
        table.add_row(
            row.medium.value,
            row.mode.value,
            str(len(v.runs)),
            str(driven_samples(row)),
            f"{v.metres:.1f}",
            *(fraction_text(v, a) for a in AXES),
            "-" if v.power_w_per_mps is None else f"{v.power_w_per_mps:.0f}",
        )
    return table


def _picks(rep: GroundReport) -> list[str]:
    lines = []
    for medium, mode in rep.picks.items():
        why = "by the profile" if medium in rep.decided else "the default: too little learnt"
        lines.append(f"  {medium.value:<6} {mode.value:<7} ({why})")
    return lines


def ground_command(
    runs: Annotated[
        list[Path] | None,
        typer.Argument(help="run directories to identify from alone (flight.csv + the map)"),
    ] = None,
    config: ConfigOpt = None,
    media: Annotated[
        Path | None,
        typer.Option("--media", help="media map of the runs (default: media.media_map)"),
    ] = None,
    pin: Annotated[
        list[str] | None,
        typer.Option(
            "--pin",
            metavar="<medium/mode/axis=f>",
            help="set a fraction by hand: MEDIUM/MODE/AXIS=F (repeatable)",
        ),
    ] = None,
    reset: Annotated[bool, typer.Option("--reset", help="forget the whole profile")] = False,
    plot: Annotated[
        Path | None, typer.Option("--plot", help="also draw the fractions into this PNG")
    ] = None,
) -> None:
    """Show the ground profile (per medium and mode: samples, metres, fractions ± σ, W per
    m/s, runs) and the mode media.modes learned picks; or identify from given runs alone."""
    cfg = config_or_exit(config)
    path = profile_path(cfg)
    try:
        if runs:
            where = media or cfg.media.media_map
            if where is None:
                raise fail(["helixd ground RUN…: needs --media MAP (or media.media_map)"])
            profile = from_runs(cfg, runs, read_media_map(where))
            source = f"{len(runs)} run(s) over {where}"
        else:
            if reset and path.exists():
                path.unlink()
            profile = read_profile(path)
            for text in pin or []:
                key, value = parse_pin(text)
                profile.pins[key] = value
            if pin:
                write_profile(path, profile)
            source = str(path)
    except GroundCommandError as exc:
        raise fail(exc.problems, ExitCode.USAGE) from None
    except (ConfigFileError, MediaMapError) as exc:
        raise fail(exc.problems, ExitCode.USAGE) from None
    rep = report(cfg, profile, source)
    console = Console(width=140)
    console.print(_table(rep))
    typer.echo("media.modes learned picks (ground.objective " + cfg.ground.objective + "):")
    for line in _picks(rep):
        typer.echo(line)
    if plot is not None:
        from helixd.commands.ground_plot import plot_report  # matplotlib only when drawing

        plot_report(rep, plot)
        typer.echo(f"figure: {plot}")


def register(app: typer.Typer) -> None:
    """Add ``ground`` to ``app``."""
    app.command("ground")(ground_command)
