"""The commands that read a run directory: ``helixd plot``, ``helixd replay`` and
``helixd export``."""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Annotated, TextIO

import typer
from rich.console import Console
from rich.table import Table

from helixd.base.exitcodes import ExitCode
from helixd.base.run_files import EVENTS_FILE, FLIGHT_FILE, SUMMARY_FILE
from helixd.files.yamlio import clip_line
from helixd.recorder.clocks import ClockMap
from helixd.recorder.events import read_events, timeline
from helixd.recorder.export import (
    DEFAULT_MIN_STEP_M,
    ExportError,
    load_run_export,
    to_geojson,
    to_kml,
)
from helixd.recorder.logging_setup import configure_logging
from helixd.recorder.rows import Value, read_flight_csv
from helixd.recorder.summary import RunSummary
from helixd.report.display import summary_rows, summary_table

RunDirArg = Annotated[
    Path,
    typer.Argument(help="run directory (runs/<UTC stamp>-<mission>/)", show_default=False),
]


def _check_run_dir(run_dir: Path) -> None:
    if not run_dir.is_dir():
        typer.echo(f"error: {run_dir}: not a directory", err=True)
        raise typer.Exit(int(ExitCode.USAGE))
    if not any((run_dir / name).exists() for name in (FLIGHT_FILE, SUMMARY_FILE, EVENTS_FILE)):
        typer.echo(
            f"error: {run_dir}: no {FLIGHT_FILE}, {SUMMARY_FILE} or {EVENTS_FILE}; "
            "is this a helixd run directory?",
            err=True,
        )
        raise typer.Exit(int(ExitCode.USAGE))


def load_summary(run_dir: Path) -> tuple[RunSummary | None, str | None]:
    """The run's summary, or None and the reason it is missing/unreadable."""
    path = run_dir / SUMMARY_FILE
    try:
        return RunSummary.from_json(path.read_text(encoding="utf-8")), None
    except FileNotFoundError:
        return None, f"no {SUMMARY_FILE}: the run did not finish cleanly (crash or power loss?)"
    except (OSError, ValueError) as exc:
        return None, f"{path}: unreadable ({exc})"


def _seconds(value: float | None) -> str:
    return f"{'-':>9}" if value is None else f"{value:9.3f}"


def clock_map(rows: list[dict[str, Value]]) -> ClockMap:
    """Both clocks of ``flight.csv`` rows (missing or non-numeric cells are skipped)."""

    def num(row: dict[str, Value], key: str) -> float:
        v = row.get(key)
        return float(v) if isinstance(v, int | float) and not isinstance(v, bool) else math.nan

    return ClockMap([num(r, "t_mono_s") for r in rows], [num(r, "t_boot_s") for r in rows])


def _times_note(clocks: ClockMap) -> str:
    if not clocks.has_rows:
        return "times: wall clock (s) since the run started; no control step was recorded"
    note = "times (s) from the first control step, negative before it: autopilot clock, wall clock"
    if clocks.has_autopilot and abs(clocks.rate - 1.0) > 0.01:
        note += f" (the autopilot clock ran {clocks.rate:.2f}x the wall clock)"
    return note


def print_replay(
    run_dir: Path, *, tty: bool, include_periodic: bool = False, out: TextIO | None = None
) -> None:
    """Print the summary and the event timeline (rich tables on a terminal, plain otherwise)."""
    stream = out if out is not None else sys.stdout
    summary, problem = load_summary(run_dir)
    flight = run_dir / FLIGHT_FILE
    flight_rows = read_flight_csv(flight) if flight.is_file() else []
    rows = len(flight_rows)
    clocks = clock_map(flight_rows)
    entries = timeline(
        read_events(run_dir / EVENTS_FILE), include_periodic=include_periodic, clocks=clocks
    )
    if tty:
        console = Console(file=stream)
        if summary is not None:
            console.print(summary_table(summary, run_dir))
        else:
            console.print(f"[bold red]{problem}[/]")
        console.print(f"flight.csv: {rows} rows")
        table = Table(title=f"events ({len(entries)})", caption=_times_note(clocks))
        for name, justify in (
            ("autopilot (s)", "right"),
            ("wall (s)", "right"),
            ("level", "left"),
            ("event", "left"),
        ):
            table.add_column(name, justify=justify)  # type: ignore[arg-type]
        table.add_column("details", overflow="fold")
        for e in entries:
            style = "red" if e.level in ("error", "critical") else None
            style = style or ("yellow" if e.level == "warning" else None)
            table.add_row(
                _seconds(e.t_ap_s), _seconds(e.t_s), e.level, e.event, e.fields, style=style
            )
        console.print(table)
        return
    lines: list[str] = [f"run: {run_dir}"]
    if summary is not None:
        width = max(len(label) for label, _ in summary_rows(summary))
        lines += [f"{label:<{width}}  {value}" for label, value in summary_rows(summary)]
    else:
        lines.append(f"summary: {problem}")
    lines.append(f"flight.csv: {rows} rows")
    lines.append(f"events ({len(entries)}); {_times_note(clocks)}:")
    lines.append(f"{'autopilot':>9} {'wall':>9}  {'level':<8} event  details")
    lines += [
        f"{_seconds(e.t_ap_s)} {_seconds(e.t_s)}  {e.level:<8} {e.event}  {e.fields}".rstrip()
        for e in entries
    ]
    typer.echo("\n".join(lines), file=stream)


def plot_command(
    run_dir: RunDirArg,
    out: Annotated[
        Path | None,
        typer.Option("--out", "-o", help="output directory (default: RUN_DIR/plots)"),
    ] = None,
) -> None:
    """Render the thesis-style plots (a)–(f) and an overview of a recorded run as PNGs."""
    configure_logging(tty=sys.stderr.isatty(), level="warning")
    _check_run_dir(run_dir)
    from helixd.recorder.plots import render_run  # matplotlib only when plotting
    from helixd.recorder.run_data import PlotError

    try:
        paths = render_run(run_dir, out)
    except PlotError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(int(ExitCode.USAGE)) from None
    except OSError as exc:
        typer.echo(f"error: cannot write plots: {exc}", err=True)
        raise typer.Exit(int(ExitCode.USAGE)) from None
    for path in paths:
        typer.echo(str(path))


def replay_command(
    run_dir: RunDirArg,
    all_events: Annotated[
        bool, typer.Option("--all", help="also list periodic progress events")
    ] = False,
) -> None:
    """Print a recorded run's summary and its event timeline."""
    configure_logging(tty=sys.stderr.isatty(), level="warning")
    _check_run_dir(run_dir)
    print_replay(run_dir, tty=sys.stdout.isatty(), include_periodic=all_events)


def export_command(
    run_dir: Annotated[Path, typer.Argument(help="run directory (runs/<stamp>-<mission>/)")],
    geojson: Annotated[
        bool, typer.Option("--geojson", help="write GeoJSON (the default without a format)")
    ] = False,
    kml: Annotated[
        bool, typer.Option("--kml", help="write KML (also the default for an --out of .kml)")
    ] = False,
    out: Annotated[
        Path | None,
        typer.Option("-o", "--out", help="output file (default: RUN_DIR/track.geojson|kml)"),
    ] = None,
    min_step_m: Annotated[
        float,
        typer.Option("--min-step-m", min=0.0, max=100.0, help="flown-track point spacing (m)"),
    ] = DEFAULT_MIN_STEP_M,
) -> None:
    """Export the planned path and the flown track in lat/lon (GeoJSON, or KML)."""
    if geojson and kml:
        typer.echo("error: give one of --geojson or --kml", err=True)
        raise typer.Exit(int(ExitCode.USAGE))
    if not kml:  # no format given: KML for a .kml file, else GeoJSON
        geojson = geojson or out is None or out.suffix.lower() != ".kml"
    if not run_dir.is_dir():
        typer.echo(f"error: {run_dir}: not a directory", err=True)
        raise typer.Exit(int(ExitCode.USAGE))
    try:
        data = load_run_export(run_dir, min_step_m)
    except ExportError as exc:
        typer.echo(f"error: {clip_line(str(exc))}", err=True)
        raise typer.Exit(int(ExitCode.USAGE)) from None
    target = out or run_dir / ("track.geojson" if geojson else "track.kml")
    text = to_geojson(data) if geojson else to_kml(data)
    try:
        target.write_text(text, encoding="utf-8")
    except OSError as exc:
        typer.echo(f"error: {target}: cannot write: {exc.strerror or exc}", err=True)
        raise typer.Exit(int(ExitCode.USAGE)) from None
    typer.echo(
        f"{target}: planned {len(data.planned)} waypoints, flown track {len(data.flown)} "
        f"points (EKF origin {data.origin[0]:.7f}, {data.origin[1]:.7f})"
    )


def register(app: typer.Typer) -> None:
    """Add ``plot``, ``replay`` and ``export`` to ``app``."""
    app.command("plot")(plot_command)
    app.command("replay")(replay_command)
    app.command("export")(export_command)
