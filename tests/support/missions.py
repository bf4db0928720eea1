"""Missions written in tests: a mission from its frame and items, and one from points (one
place, so test modules do not repeat the YAML-shaped dictionary)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import yaml

from helixd.mission.model import Mission

FRAME_KEYS = {"start": ("x", "y"), "local_ned": ("north", "east"), "global": ("lat", "lon")}


def mission_of(
    frame: str, items: Sequence[dict[str, Any]], mode: str = "roll", name: str = "t", **extra: Any
) -> Mission:
    """The mission ``name`` flown in ``mode`` with ``items`` (waypoints and commands as a
    mission file writes them) in ``frame``; ``extra``: more top-level keys."""
    return Mission.model_validate(
        {"name": name, "mode": mode, "frame": frame, "waypoints": list(items), **extra}
    )


def points_items(frame: str, points: Sequence[tuple[float, float]]) -> list[dict[str, float]]:
    """Plain waypoints at ``points`` (the frame's two coordinates), as a mission file writes
    them."""
    a, b = FRAME_KEYS[frame]
    return [{a: p, b: q} for p, q in points]


def points_mission(
    frame: str, points: Sequence[tuple[float, float]], mode: str = "omni", **extra: Any
) -> Mission:
    """A mission of plain waypoints at ``points`` (the frame's two coordinates)."""
    return mission_of(frame, points_items(frame, points), mode, **extra)


def mission_file(path: Path, doc: dict[str, Any]) -> Path:
    """The mission ``doc`` (a mission file's keys) written to ``path`` as YAML; ``path``."""
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    return path
