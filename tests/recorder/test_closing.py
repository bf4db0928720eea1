"""helixd.recorder.closing: a run directory whose writer was killed, closed from its record."""

from __future__ import annotations

import io
import json
from pathlib import Path

from helixd.base.run_files import EVENTS_FILE, FLIGHT_FILE, SUMMARY_FILE
from helixd.cli.runs import print_replay
from helixd.recorder.closing import (
    KILLED_CAUSE,
    KILLED_EXIT_CODE,
    close_killed_run,
    cut_run,
)
from helixd.recorder.rows import CSV_COMMENT, FlightRow, RowFormatter, nan_row
from helixd.recorder.rundir import RESERVE_FILE


def _row(t: float, north: float) -> FlightRow:
    return nan_row(
        t_boot_s=100.0 + t, t_mono_s=t, x_m=0.0, y_m=north, north_m=north, east_m=0.0,
        pose_fresh=True, cross_track_m=0.1, distance_error_m=10.0 - north,
    )  # fmt: skip


def killed_run(tmp_path: Path) -> Path:
    """A run killed mid-write: 11 rows (1 m apart, 1 s apart) and a torn 12th; two
    waypoints reached; the last event line torn too; the summary's reserve still there."""
    run = tmp_path / "20260101T000000Z-lane"
    run.mkdir()
    fmt = RowFormatter()
    lines = [fmt.line(_row(float(k), float(k))) for k in range(11)]
    torn = fmt.line(_row(11.0, 11.0))[:25]
    (run / FLIGHT_FILE).write_text(
        CSV_COMMENT + "\n" + FlightRow.csv_header() + "".join(lines) + torn, encoding="utf-8"
    )
    events = [
        {"event": "run_started", "mission": "lane", "run_dir": str(run), "t_mono_s": 0.0},
        {"event": "waypoint_reached", "waypoint": "1/3", "index": 0, "t_boot_s": 104.0,
         "error_m": 0.2},
        {"event": "waypoint_reached", "waypoint": "2/3", "index": 1, "t_boot_s": 108.0,
         "error_m": 0.3},
    ]  # fmt: skip
    text = "".join(json.dumps(e) + "\n" for e in events) + '{"event": "progress", "wayp'
    (run / EVENTS_FILE).write_text(text, encoding="utf-8")
    (run / RESERVE_FILE).write_bytes(b"\0" * 1024)
    return run


def test_a_killed_run_is_closed_from_what_it_recorded_and_replay_reads_it(
    tmp_path: Path,
) -> None:
    run = killed_run(tmp_path)
    assert cut_run(run)
    summary = close_killed_run(run)
    assert summary is not None
    assert not cut_run(run) and not (run / RESERVE_FILE).exists()
    written = json.loads((run / SUMMARY_FILE).read_text(encoding="utf-8"))
    assert written["completed"] is False and written["exit_code"] == KILLED_EXIT_CODE
    assert written["fault"].startswith(f"{KILLED_CAUSE}: ")
    assert written["mission_name"] == "lane"
    assert written["rows"] == 11  # the torn row skipped
    assert written["waypoints_reached"] == 2 and written["waypoints_total"] == 3
    assert [a["number"] for a in written["arrivals"]] == [1, 2]
    assert abs(written["duration_s"] - 10.0) < 1e-6  # autopilot clock, first to last row
    assert abs(written["path_length_m"] - 10.0) < 1e-6
    out = io.StringIO()
    print_replay(run, tty=False, out=out)
    assert "killed" in out.getvalue()
    assert close_killed_run(run) is None  # closed once: nothing more to do


def test_a_run_killed_before_its_first_row_is_closed_not_flown(tmp_path: Path) -> None:
    run = tmp_path / "run"
    run.mkdir()
    (run / FLIGHT_FILE).write_text(CSV_COMMENT + "\n" + FlightRow.csv_header()[:10])
    summary = close_killed_run(run)  # no events at all, a torn header
    assert summary is not None and summary.rows == 0 and summary.waypoints_reached == 0
    assert summary.mission_name == "run"
    print_replay(run, tty=False, out=io.StringIO())
