"""ArduPilot parameter files (``.parm``, as SITL's ``--defaults``, Mission Planner and
QGroundControl save them): one ``NAME VALUE`` (or ``NAME,VALUE``) per line, ``#`` comments.

A file may be hostile: it is read bounded (:data:`MAX_FILE_BYTES`), strict UTF-8, and every
line must name a parameter ArduPilot could have (1..16 of ``A-Z 0-9 _``, starting with a
letter) and a finite number; a name given twice is refused. Each problem is one line naming
the file and the line number.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from types import MappingProxyType

from helixd.base.problems import Problems
from helixd.files.yamlio import clip, finite_number

MAX_FILE_BYTES = 1_000_000  # a full Rover parameter dump is about 30 kB
PARAM_NAME = re.compile(r"[A-Z][A-Z0-9_]{0,15}")  # AP_MAX_NAME_SIZE 16


class ParmFileError(Problems, ValueError):
    """The file cannot be used; ``problems`` holds one line per problem."""

    joiner = "; "


def parse_parm(text: str, source: str) -> Mapping[str, float]:
    """``NAME → value`` in file order; :class:`ParmFileError` lists every bad line."""
    values: dict[str, float] = {}
    first_seen: dict[str, int] = {}
    problems: list[str] = []
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        fields = line.replace(",", " ").split()
        where = f"{source}:{number}"
        if len(fields) != 2:
            problems.append(f"{where}: expected 'NAME VALUE', got {clip(line, 60)}")
            continue
        name, text_value = fields
        if PARAM_NAME.fullmatch(name) is None:
            problems.append(
                f"{where}: {clip(name, 40)} is not a parameter name "
                "(1-16 of A-Z, 0-9, _; starting with a letter)"
            )
            continue
        try:
            value = finite_number(text_value, f"{name} =")
        except ValueError as exc:
            problems.append(f"{where}: {exc}")
            continue
        if name in first_seen:
            problems.append(f"{where}: {name} set again (first on line {first_seen[name]})")
            continue
        first_seen[name] = number
        values[name] = value
    if problems:
        raise ParmFileError(problems)
    return MappingProxyType(values)


def load_parm(path: Path) -> Mapping[str, float]:
    """:func:`parse_parm` of a file, read bounded and as strict UTF-8."""
    try:
        with path.open("rb") as fh:
            data = fh.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise ParmFileError([f"{path}: cannot read: {exc.strerror or exc}"]) from None
    if len(data) > MAX_FILE_BYTES:
        raise ParmFileError([f"{path}: larger than {MAX_FILE_BYTES} bytes: not a parameter file"])
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ParmFileError([f"{path}: not UTF-8 (byte {exc.start})"]) from None
    return parse_parm(text, str(path))
