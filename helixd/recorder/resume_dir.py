"""Reading a run directory for ``helixd run --resume`` (the I/O shell of
:mod:`helixd.mission.resume`). Anything missing or unreadable becomes one
:class:`~helixd.mission.resume.ResumeRefused` line; nothing in it is trusted."""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from helixd.base.plan import Numbering
from helixd.base.run_files import (
    EVENTS_FILE,
    FLIGHT_FILE,
    INPUTS_FILE,
    MISSION_FILE,
    SUMMARY_FILE,
)
from helixd.mission.resume import ResumeRefused, RunInputs, parse_inputs
from helixd.recorder.events import RUN_STARTED_EVENT, read_events

MAX_INPUT_BYTES = 10_000_000  # inputs.json, mission.yaml, summary.json: larger is not ours


@dataclass(frozen=True, slots=True)
class RunDirContents:
    inputs_text: str
    mission_yaml: str
    events: list[dict[str, Any]]
    completed: bool  # summary.json says so (no summary: a crash or power loss, not completed)
    # where the interrupted run left the rover: (north_m, east_m, yaw_ned_rad) of the last
    # flight.csv row with a finite pose; None without one
    last_pose_ned: tuple[float, float, float] | None = None


def _read(path: Path, what: str) -> str:
    try:
        if path.stat().st_size > MAX_INPUT_BYTES:
            raise ResumeRefused(f"{path}: too large for a {what}")
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ResumeRefused(f"{path}: missing ({what})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ResumeRefused(f"{path}: cannot read {what}: {exc}") from None


def read_run_dir(run_dir: Path) -> RunDirContents:
    """The parts of a run directory a resume needs, or ResumeRefused saying what is wrong."""
    if not run_dir.is_dir():
        raise ResumeRefused(f"{run_dir}: not a run directory (missing or not a directory)")
    if not (run_dir / INPUTS_FILE).exists():
        raise ResumeRefused(
            f"{run_dir}: no {INPUTS_FILE} (recorded by a helixd without mission/config "
            "hashes), so an unchanged mission and config cannot be proven; cannot resume"
        )
    inputs_text = _read(run_dir / INPUTS_FILE, "run inputs record")
    mission_yaml = _read(run_dir / MISSION_FILE, "mission file")
    events_path = run_dir / EVENTS_FILE
    if not events_path.is_file():
        raise ResumeRefused(f"{events_path}: missing (event log)")
    events = read_events(events_path)  # torn/garbage lines are skipped
    if not any(ev.get("event") == RUN_STARTED_EVENT for ev in events):
        raise ResumeRefused(f"{events_path}: no {RUN_STARTED_EVENT} event: corrupt event log")
    completed = False
    summary_path = run_dir / SUMMARY_FILE
    if summary_path.exists():
        text = _read(summary_path, "run summary")
        try:
            data = json.loads(text)
        except json.JSONDecodeError:
            raise ResumeRefused(f"{summary_path}: corrupt (not JSON)") from None
        done = data.get("completed") if isinstance(data, dict) else None
        if not isinstance(done, bool):
            raise ResumeRefused(f"{summary_path}: corrupt (no boolean 'completed')")
        completed = done
    last = last_pose_ned(run_dir / FLIGHT_FILE)
    return RunDirContents(inputs_text, mission_yaml, events, completed, last)


TAIL_BYTES = 65_536  # the last pose is looked for in this much of flight.csv's end
POSE_COLUMNS = ("north_m", "east_m", "yaw_ned_rad")


def last_pose_ned(flight_csv: Path) -> tuple[float, float, float] | None:
    """The last finite (north_m, east_m, yaw_ned_rad) of ``flight.csv``, read from its header
    and its last :data:`TAIL_BYTES` only (a run of hours has millions of rows); None when
    there is none or the file is unreadable (nothing in it is trusted)."""
    try:
        with flight_csv.open("rb") as f:
            head = [f.readline() for _ in range(3)]
            size = f.seek(0, 2)
            f.seek(max(0, size - TAIL_BYTES))
            tail = f.read(TAIL_BYTES)
    except OSError:
        return None
    header = next(
        (h.decode("utf-8", "replace").strip() for h in head if h and not h.startswith(b"#")), ""
    )
    names = header.split(",")
    if not all(c in names for c in POSE_COLUMNS):
        return None
    cols = [names.index(c) for c in POSE_COLUMNS]
    for line in reversed(tail.decode("utf-8", "replace").splitlines()[1:]):  # first: torn
        cells = line.split(",")
        if len(cells) != len(names):
            continue
        try:
            north, east, yaw = (float(cells[k]) for k in cols)
        except ValueError:
            continue
        if all(math.isfinite(v) for v in (north, east, yaw)) and max(abs(north), abs(east)) < 1e6:
            return north, east, math.remainder(yaw, math.tau)
    return None


def recorded_inputs(run_dir: Path) -> RunInputs | None:
    """The run's ``inputs.json`` (None when missing or unreadable: an older run, a crash)."""
    try:
        return parse_inputs(_read(run_dir / INPUTS_FILE, "run inputs record"))
    except ResumeRefused:
        return None


def run_numbering(run_dir: Path, vias: Sequence[bool]) -> Numbering:
    """The operator's numbering of a run's waypoints (``vias``: its mission's via flags):
    from its ``inputs.json`` (a resumed run continues the mission's count), else from 1."""
    inputs = recorded_inputs(run_dir)
    return Numbering.of(vias) if inputs is None else inputs.numbering(vias)


__all__ = ["RunDirContents", "last_pose_ned", "read_run_dir", "recorded_inputs", "run_numbering"]
