"""Mission Planner / QGroundControl ``.waypoints`` files (``QGC WPL 110``), read and written.

Each row: ``INDEX CURRENT FRAME COMMAND P1 P2 P3 P4 X(lat) Y(lon) Z AUTOCONTINUE``, tab
separated. Row 0 is home on ArduPilot (Mission Planner writes the home position there), so it is
read as home and never flown.

Why not pymavlink's ``mavwp.MAVWPLoader`` (MAVProxy's reader, tried first): it builds
MISSION_ITEM messages of whatever dialect pymavlink has loaded process-wide and fails with
``TypeError: ... takes 15 positional arguments but 16 were given`` when ``MAVLINK20`` and the
loaded dialect disagree (as in this daemon); it accepts ``nan``/``inf``, names no line, and
reads files of any size. What it parses is a 12-column split; that split is done here, with the
same columns, and every value is bounded and finite; a problem names file, line and column.
"""

from __future__ import annotations

import math
from pathlib import Path

from helixd.files.yamlio import clip, finite_number
from helixd.mav.mission_item import MissionItem
from helixd.mission.formats.items import (
    MAX_ITEMS,
    FenceRow,
    FormatError,
    GcsMission,
    check_latlon,
    fence_shapes,
)

HEADER = "QGC WPL 110"


FENCE_COMMANDS = range(5000, 5005)  # MAV_CMD_NAV_FENCE_RETURN_POINT .. _CIRCLE_EXCLUSION


def parse_wpl_text(text: str, source: Path | str) -> GcsMission:
    """A mission file; a fence file (rows with commands 5000–5004) is refused, saying so."""
    src = str(source)
    rows = _rows(text, src)
    fence = [lineno for lineno, item in rows if item.command in FENCE_COMMANDS]
    if fence:
        raise FormatError(
            [
                f"{src}: a fence file (QGC WPL 110 rows with fence commands 5000-5004, line "
                f"{fence[0]}), not a mission: give it with --fence {src}"
            ]
        )
    _check_sequence(rows, src)
    home_line, home = rows[0]
    bad = check_latlon(f"{src}: line {home_line} (home)", home.x, home.y)
    home_latlon = None if bad else (home.x, home.y)
    problems: list[str] = []
    for lineno, item in rows[1:]:
        if item.command == 16 and not (item.x == 0.0 and item.y == 0.0):
            # 0, 0 is "where the rover is"; others may carry no position at all
            problems += check_latlon(f"{src}: line {lineno}", item.x, item.y)
    if problems:
        raise FormatError(problems[:20])
    return GcsMission(
        items=tuple(item for _, item in rows[1:]),
        home_latlon_deg=home_latlon,
        home_alt_m=None if home_latlon is None or not math.isfinite(home.z) else home.z,
    )


def parse_wpl_fence_text(text: str, source: Path | str) -> GcsMission:
    """A Mission Planner fence file: QGC WPL 110 rows of fence commands (no home row), read
    into polygons (param1 = vertex count) and circles (param1 = radius)."""
    src = str(source)
    rows = _rows(text, src)
    other = [(n, it.command) for n, it in rows if it.command not in FENCE_COMMANDS]
    if other:
        n, cmd = other[0]
        raise FormatError(
            [f"{src}: line {n}: command {cmd} is not a fence command (5000-5004): not a fence file"]
        )
    for k, (lineno, item) in enumerate(rows):
        if item.seq != k:
            raise FormatError(
                [f"{src}: line {lineno}: index {item.seq}, expected {k} (rows must count 0, 1, …)"]
            )
    shapes = [
        FenceRow(it.seq, it.command, it.param1, it.x, it.y, f"{src}: line {n}") for n, it in rows
    ]
    polygons, circles, notes = fence_shapes(shapes)
    return GcsMission(
        items=(), polygons=tuple(polygons), circles=tuple(circles), notes=tuple(notes)
    )


def _check_sequence(rows: list[tuple[int, MissionItem]], src: str) -> None:
    for k, (lineno, item) in enumerate(rows):
        if item.seq != k:
            raise FormatError(
                [f"{src}: line {lineno}: index {item.seq}, expected {k} (rows must count 0, 1, …)"]
            )


def _rows(text: str, src: str) -> list[tuple[int, MissionItem]]:
    lines = text.splitlines()
    if not lines or lines[0].strip() != HEADER:
        first = clip(lines[0].strip(), 40) if lines else "(empty file)"
        raise FormatError(
            [f"{src}: line 1: expected the header {HEADER!r}, got {first} (not a .waypoints file)"]
        )
    rows: list[tuple[int, MissionItem]] = []
    problems: list[str] = []
    for lineno, line in enumerate(lines[1:], start=2):
        if not line.strip() or line.startswith("#"):
            continue
        if len(rows) >= MAX_ITEMS + 1:
            raise FormatError([f"{src}: more than {MAX_ITEMS} mission items; refused"])
        item, bad = _row(line, lineno, src)
        if item is None:
            problems.extend(bad)
            if len(problems) >= 20:
                break
            continue
        rows.append((lineno, item))
    if problems:
        raise FormatError(problems[:20])
    if not rows:
        raise FormatError([f"{src}: no rows after the header: nothing to fly"])
    return rows


_INT_COLUMNS = {0: "index", 1: "current", 2: "frame", 3: "command", 11: "autocontinue"}
_FLOAT_COLUMNS = {4: "param1", 5: "param2", 6: "param3", 7: "param4", 8: "x", 9: "y", 10: "z"}
_INT_MAX = {0: MAX_ITEMS + 1, 1: 1, 2: 255, 3: 65535, 11: 1}


def _row(line: str, lineno: int, src: str) -> tuple[MissionItem | None, list[str]]:
    """One row → item, or the problems naming line and column (as mavwp's row parser reads it:
    whitespace-separated, 12 values; but finite and bounded here)."""
    cols = line.split()
    where = f"{src}: line {lineno}"
    if len(cols) != 12:
        return None, [f"{where}: {len(cols)} values, a QGC WPL 110 row has 12"]
    ints: dict[int, int] = {}
    floats: dict[int, float] = {}
    problems: list[str] = []
    for i, name in _INT_COLUMNS.items():
        text = cols[i]
        if not (text.isascii() and text.isdigit() and len(text) <= 6):
            problems.append(f"{where}: {name} {clip(text, 40)} is not a whole number 0..")
            continue
        value = int(text)
        if value > _INT_MAX[i]:
            problems.append(f"{where}: {name} {value} is above {_INT_MAX[i]}")
        ints[i] = value
    for i, name in _FLOAT_COLUMNS.items():
        text = cols[i]
        try:
            floats[i] = finite_number(text, name)
        except ValueError as exc:
            problems.append(f"{where}: {exc}")
    if problems:
        return None, problems
    item = MissionItem(
        seq=ints[0],
        frame=ints[2],
        command=ints[3],
        param1=floats[4],
        param2=floats[5],
        param3=floats[6],
        param4=floats[7],
        x=floats[8],
        y=floats[9],
        z=floats[10],
        autocontinue=bool(ints[11]),
        where=f"line {lineno}",
    )
    return item, []


def _fmt(v: float) -> str:
    return f"{v:.8f}" if math.isfinite(v) else "0.00000000"


def wpl_to_text(gcs: GcsMission) -> str:
    """QGC WPL 110 as Mission Planner writes it: row 0 home (frame 0, current 1)."""
    home = gcs.home_latlon_deg or ((gcs.items[0].x, gcs.items[0].y) if gcs.items else (0.0, 0.0))
    out = [HEADER]
    out.append(
        "\t".join(
            [
                "0",
                "1",
                "0",
                "16",
                *(_fmt(0.0) for _ in range(4)),
                _fmt(home[0]),
                _fmt(home[1]),
                _fmt(gcs.home_alt_m or 0.0),
                "1",
            ]
        )
    )
    for i, it in enumerate(gcs.items, start=1):
        params = (it.param1, it.param2, it.param3, it.param4)
        out.append(
            "\t".join(
                [
                    str(i),
                    "0",
                    str(it.frame),
                    str(it.command),
                    *(_fmt(p) for p in params),
                    _fmt(it.x),
                    _fmt(it.y),
                    _fmt(it.z),
                    "1" if it.autocontinue else "0",
                ]
            )
        )
    return "\n".join(out) + "\n"
