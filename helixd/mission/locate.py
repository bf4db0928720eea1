"""Find a mission file by name: ``--mission square.yaml`` works from the repository root.

A path that exists as given is used as given. A *bare* name (no directory part) that does not
exist is looked up in :data:`SEARCH_DIRS`, in order; ``square`` also finds ``square.yaml``.
A missing file's message names every place searched.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

SEARCH_DIRS = (Path("config/missions"), Path("/etc/helixd/missions"))
SUFFIXES = (".yaml", ".yml", ".plan", ".waypoints")


@dataclass(frozen=True, slots=True)
class MissionLocation:
    path: Path
    searched: bool  # True when found by name in a search directory, not as given


class MissionNotFound(Exception):
    """No file for the given mission name; the message names every place searched."""


def _candidates(given: Path, search_dirs: tuple[Path, ...]) -> list[Path]:
    names = [given.name]
    if given.suffix not in SUFFIXES:
        names += [given.name + s for s in SUFFIXES]
    return [d / n for d in search_dirs for n in names]


def locate_mission(given: Path, search_dirs: tuple[Path, ...] = SEARCH_DIRS) -> MissionLocation:
    """Return where ``given`` is, or raise :class:`MissionNotFound`."""
    if given.exists():
        return MissionLocation(given, searched=False)
    bare = given.parent == Path(".") and given.name not in ("", ".", "..")
    if not bare:
        raise MissionNotFound(f"{given}: file not found")
    tried = _candidates(given, search_dirs)
    for candidate in tried:
        if candidate.is_file():
            return MissionLocation(candidate, searched=True)
    places = ", ".join(str(p) for p in [given, *tried])
    raise MissionNotFound(f"{given}: mission file not found; looked for {places}")


def available_missions(search_dirs: tuple[Path, ...] = SEARCH_DIRS) -> list[str]:
    """The mission files a bare ``--mission`` name would find, as ``dir/name``, sorted."""
    found: list[str] = []
    for d in search_dirs:
        try:
            names = sorted(p.name for p in d.iterdir() if p.suffix in SUFFIXES and p.is_file())
        except OSError:
            continue
        found += [str(d / n) for n in names]
    return found
