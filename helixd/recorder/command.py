"""CLI commands contributed by helixd.recorder (registered by helixd.cli)."""

from __future__ import annotations

import typer


def register(app: typer.Typer) -> None:
    """Add this package's commands to the main CLI (filled in by its owner)."""
    del app
