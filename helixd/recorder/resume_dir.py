"""Reading a run directory for ``helixd run --resume`` (the I/O shell of
:mod:`helixd.mission.resume`). Anything missing or unreadable becomes one
:class:`~helixd.mission.resume.ResumeRefused` line; nothing in it is trusted."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from helixd.base.run_files import EVENTS_FILE, INPUTS_FILE, MISSION_FILE, SUMMARY_FILE
from helixd.mission.resume import ResumeRefused
from helixd.recorder.events import RUN_STARTED_EVENT, read_events

MAX_INPUT_BYTES = 10_000_000  # inputs.json, mission.yaml, summary.json: larger is not ours


@dataclass(frozen=True, slots=True)
class RunDirContents:
    inputs_text: str
    mission_yaml: str
    events: list[dict[str, Any]]
    completed: bool  # summary.json says so (no summary: a crash or power loss, not completed)


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
    return RunDirContents(inputs_text, mission_yaml, events, completed)


__all__ = ["RunDirContents", "read_run_dir"]
