"""Closing a run directory its writer never closed: ``helixd`` killed (kill -9, the OOM
killer, a hung process stopped by systemd's watchdog, a power cut) leaves a run directory
without ``summary.json``. The next start of ``helixd serve`` finds it through its state file
(:mod:`helixd.serve.flights`) and closes it here, from what the run recorded: the rows of
``flight.csv`` (time span, distance, cross-track) and the ``waypoint_reached`` events of
``events.jsonl``. Nothing in either is trusted: a torn last line (the kill mid-write) or a
garbage one is skipped. ``helixd replay`` then reads the run as any other, its fault saying it
was cut (:data:`KILLED_CAUSE`)."""

from __future__ import annotations

import csv
import os
import re
from pathlib import Path
from typing import Any

import structlog

from helixd.base.clock import on_simulated_clock
from helixd.base.run_files import EVENTS_FILE, FLIGHT_FILE, SUMMARY_FILE
from helixd.mission.resume import WAYPOINT_REACHED_EVENT
from helixd.recorder.events import RUN_STARTED_EVENT, read_events
from helixd.recorder.resume_dir import recorded_inputs
from helixd.recorder.rows import COMMENT_PREFIX, nan_row
from helixd.recorder.rundir import RESERVE_FILE
from helixd.recorder.summary import RunSummary, SummaryBuilder

log = structlog.get_logger(__name__)

KILLED_CAUSE = "killed"  # the summary's fault starts with it (helixd.recorder.outcome)
# the status a shell or systemd reports for a process killed by SIGKILL (128 + 9): no
# ExitCode of helixd's own, which are what a helixd that ended by itself returns
KILLED_EXIT_CODE = 137
KILLED_DETAIL = (
    "helixd ended without its fall-back (killed: kill -9, power cut or hang); "
    "closed at the next start from what it recorded"
)
# the columns the summary reads (helixd.recorder.summary.SummaryBuilder.add)
SUMMARY_COLUMNS = (
    "t_boot_s", "t_mono_s", "x_m", "y_m", "cross_track_m", "distance_error_m",
    "slip_vx_frac", "slip_vy_frac", "slip_w_frac",
)  # fmt: skip
_LEADING_NUMBER = re.compile(r"\s*(\d+)(?:/(\d+))?")


def cut_run(run_dir: Path) -> bool:
    """A run directory that exists and has no summary: its writer never closed it."""
    return run_dir.is_dir() and not (run_dir / SUMMARY_FILE).exists()


def _add_rows(builder: SummaryBuilder, path: Path) -> None:
    """Each whole row of ``flight.csv`` into ``builder``, streamed through one row object (a run
    of hours has millions); rows that do not parse (a torn last line) are skipped. Non-finite
    values stay as they are (the builder skips them as it does in flight)."""
    try:
        fh = path.open(encoding="utf-8", errors="replace", newline="")
    except OSError:
        return
    step = nan_row()
    with fh:
        reader = csv.reader(line for line in fh if not line.startswith(COMMENT_PREFIX))
        try:
            header = next(reader, None)
            if header is None:
                return
            width = len(header)
            where = [(c, header.index(c)) for c in SUMMARY_COLUMNS if c in header]
            fresh = header.index("pose_fresh") if "pose_fresh" in header else None
            for cells in reader:
                if len(cells) != width:
                    continue
                try:
                    for column, i in where:
                        setattr(step, column, float(cells[i]))
                except ValueError:
                    continue
                flag = cells[fresh].strip() if fresh is not None else "0"
                step.pose_fresh = flag not in ("0", "", "false", "False")
                builder.add(step)
        except (csv.Error, OSError):
            return


def _arrival(builder: SummaryBuilder, ev: dict[str, Any]) -> None:
    """One ``waypoint_reached`` event, as the flight counted it (its index, its label)."""
    index, t_boot_s, error_m = ev.get("index"), ev.get("t_boot_s"), ev.get("error_m")
    label = ev.get("waypoint")
    if not isinstance(index, int) or isinstance(index, bool) or not isinstance(label, str):
        return
    if not isinstance(t_boot_s, int | float) or not isinstance(error_m, int | float):
        return
    via = label.startswith("via")
    match = _LEADING_NUMBER.match(label.removeprefix("via → "))
    number = int(match.group(1)) if match else None
    lap = label.split("(", 1)[1].rstrip(")") if "(" in label else ""
    builder.arrival(index, float(t_boot_s), float(error_m), number=number, via=via, lap=lap)


def _total(events: list[dict[str, Any]]) -> int:
    """The operator's waypoints of the run, from the last label that counts them ("3/5")."""
    for ev in reversed(events):
        label = ev.get("waypoint")
        if ev.get("event") in (WAYPOINT_REACHED_EVENT, "progress") and isinstance(label, str):
            match = _LEADING_NUMBER.match(label.removeprefix("via → "))
            if match and match.group(2):
                return int(match.group(2))
    return 0


def killed_summary(run_dir: Path) -> RunSummary:
    """What ``run_dir`` recorded before its writer died, as a summary (pure of the run's own
    claims: nothing is completed, the fault is :data:`KILLED_CAUSE`)."""
    events = read_events(run_dir / EVENTS_FILE)  # torn and garbage lines skipped
    started = next((e for e in events if e.get("event") == RUN_STARTED_EVENT), {})
    name = started.get("mission")
    builder = SummaryBuilder(mission_name=name if isinstance(name, str) else run_dir.name)
    _add_rows(builder, run_dir / FLIGHT_FILE)
    for ev in events:
        if ev.get("event") == WAYPOINT_REACHED_EVENT:
            _arrival(builder, ev)
    inputs = recorded_inputs(run_dir)
    summary = builder.build(
        completed=False,
        fault=f"{KILLED_CAUSE}: {KILLED_DETAIL}",
        exit_code=KILLED_EXIT_CODE,
        waypoints_total=_total(events),
    )
    update: dict[str, Any] = {}
    if on_simulated_clock():  # its "wall" seconds are simulated ones
        update["companion_clock"] = "simulated"
    if inputs is not None and inputs.resumed_from is not None:
        update["resumed_from"] = inputs.resumed_from
    return summary.model_copy(update=update) if update else summary


def close_killed_run(run_dir: Path) -> RunSummary | None:
    """Close ``run_dir`` if its writer never did (:func:`cut_run`): ``summary.json`` written
    atomically from :func:`killed_summary`, the summary's space reserve let go. The summary
    written; None when there was nothing to close or it could not be written (logged)."""
    if not cut_run(run_dir):
        return None
    try:
        summary = killed_summary(run_dir)
        tmp = run_dir / (SUMMARY_FILE + ".tmp")
        with tmp.open("w", encoding="utf-8") as fh:
            fh.write(summary.to_json())
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, run_dir / SUMMARY_FILE)
        (run_dir / RESERVE_FILE).unlink(missing_ok=True)
    except (OSError, ValueError) as exc:
        log.error("killed_run_unclosed", run_dir=str(run_dir), error=str(exc))
        return None
    return summary


__all__ = [
    "KILLED_CAUSE",
    "KILLED_DETAIL",
    "KILLED_EXIT_CODE",
    "close_killed_run",
    "cut_run",
    "killed_summary",
]
