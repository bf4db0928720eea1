"""What every CLI command shares: one ``error:`` line per problem, and the config or exit 2."""

from __future__ import annotations

from pathlib import Path

import typer

from helixd.base.exitcodes import ExitCode
from helixd.config import ConfigFileError, HelixdConfig, load_config
from helixd.files.yamlio import clip_line


def fail(problems: list[str], code: ExitCode = ExitCode.USAGE) -> typer.Exit:
    """Print each problem as one ``error:`` line; the Exit to raise with ``code``."""
    for line in problems:
        typer.echo(f"error: {clip_line(line)}", err=True)
    return typer.Exit(int(code))


def config_or_exit(config: Path | None) -> HelixdConfig:
    """The config file (built-in defaults for None), or exit 2 naming every problem."""
    try:
        return load_config(config)
    except ConfigFileError as exc:
        raise fail(exc.problems) from None
