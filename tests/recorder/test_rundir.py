"""Flight recorder: run directory layout, incremental flush, degraded and refuse modes.

``synth_run`` (a realistic run directory, shared with the plot and replay tests) lives in
:mod:`tests.support.recorder_runs`.
"""

from __future__ import annotations

import errno
import io
import json
import math
import os
from dataclasses import replace
from datetime import datetime
from pathlib import Path
from typing import IO

import pytest
import structlog

from helixd.config.recorder import RecorderConfig
from helixd.recorder import logging_setup
from helixd.recorder.rows import COLUMNS, CSV_COMMENT, FlightRow, nan_row, read_flight_csv
from helixd.recorder.rundir import (
    RESERVE_FILE,
    SUMMARY_RESERVE_BYTES,
    RecorderUnavailable,
    RunRecorder,
    default_opener,
    run_dir_name,
)
from helixd.recorder.summary import SummaryBuilder
from tests.support.full_disk import FullAfter
from tests.support.recorder_runs import NOW, SQUARE_YAML, FakeClock, synth_run

pytestmark = pytest.mark.usefixtures("reset_logging")


class LogCapture:
    """configure_logging into a buffer; events parsed from the JSON tee."""

    def __init__(self, clock: FakeClock) -> None:
        self.console = io.StringIO()
        self.json = io.StringIO()
        logging_setup.configure_logging(
            tty=False, stream=self.console, json_file=self.json, clock=clock
        )

    def events(self, name: str | None = None) -> list[dict[str, object]]:
        out = [json.loads(ln) for ln in self.json.getvalue().splitlines()]
        return [e for e in out if name is None or e["event"] == name]


@pytest.fixture
def clock() -> FakeClock:
    return FakeClock()


@pytest.fixture
def logs(clock: FakeClock) -> LogCapture:
    return LogCapture(clock)


def make_row(t_s: float, **kw: object) -> FlightRow:
    base: dict[str, object] = dict(
        t_boot_s=t_s - 900.0,
        t_mono_s=t_s,
        north_m=1.0,
        east_m=2.0,
        yaw_ned_rad=0.1,
        x_m=1.0,
        y_m=2.0,
        yaw_rad=0.2,
        target_index=1,
        target_x_m=10.0,
        target_y_m=0.0,
        distance_error_m=9.0,
        heading_error_rad=0.05,
        cross_track_m=0.1,
        dist_p=0.6,
        dist_i=0.0,
        dist_d=0.01,
        yaw_p=0.4,
        yaw_i=0.0,
        yaw_d=0.0,
        vx_cmd_mps=0.6,
        vy_cmd_mps=0.0,
        wz_cmd_radps=0.1,
        speed_meas_mps=0.55,
        scroll1=0.3,
        scroll2=0.3,
        scroll3=-0.3,
        scroll4=-0.3,
        pwm1_us=1650,
        pwm2_us=1650,
        pwm3_us=1350,
        pwm4_us=1350,
        mode="MANUAL",
        armed=True,
        nav_state="track",
        link_ok=True,
        pose_fresh=True,
    )
    base.update(kw)
    return FlightRow(**base)  # type: ignore[arg-type]


def create(
    root: Path, clock: FakeClock, cfg: RecorderConfig | None = None, **kw: object
) -> RunRecorder:
    return RunRecorder.create(
        root,
        "square",
        "control: {}\n",
        SQUARE_YAML,
        cfg or RecorderConfig(),
        NOW,
        clock=clock,
        **kw,  # type: ignore[arg-type]
    )


def test_synth_run_completes_the_square(tmp_path: Path) -> None:
    run_dir, _ = synth_run(tmp_path)
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["completed"] is True
    assert summary["waypoints_reached"] == 4
    # four ~10 m legs, each ended 1 m early by the arrival tolerance
    assert 34.0 <= summary["path_length_m"] <= 38.0
    rows = read_flight_csv(run_dir / "flight.csv")
    assert len(rows) == summary["rows"]


# ---------------------------------------------------------------------------------------------
# Layout


def test_run_directory_layout(tmp_path: Path, clock: FakeClock, logs: LogCapture) -> None:
    rec = create(tmp_path / "runs", clock)
    assert rec.run_dir == tmp_path / "runs" / "20261121T031500Z-square"
    assert (rec.run_dir / "mission.yaml").read_text() == SQUARE_YAML
    assert (rec.run_dir / "config.yaml").read_text() == "control: {}\n"
    lines = (rec.run_dir / "flight.csv").read_text().splitlines()
    assert lines[0] == CSV_COMMENT and lines[0].startswith("# ")
    assert lines[1].split(",") == list(COLUMNS)
    for unit_col in ("t_boot_s", "north_m", "yaw_ned_rad", "vx_cmd_mps", "wz_cmd_radps"):
        assert unit_col in lines[1]
    events = [json.loads(x) for x in (rec.run_dir / "events.jsonl").read_text().splitlines()]
    assert events[0]["event"] == "run_started"
    assert events[0]["t_mono_s"] == clock()
    rec.close()


def test_same_second_runs_get_distinct_directories(
    tmp_path: Path, clock: FakeClock, logs: LogCapture
) -> None:
    a = create(tmp_path, clock)
    a.close()
    b = create(tmp_path, clock)
    b.close()
    assert a.run_dir is not None and b.run_dir is not None
    assert b.run_dir.name == a.run_dir.name + "-2"


def test_run_dir_name_is_utc_and_filesystem_safe() -> None:
    from datetime import timedelta, timezone

    local = datetime(2026, 11, 21, 5, 15, 0, tzinfo=timezone(timedelta(hours=2)))
    assert run_dir_name("my mission/../x", local) == "20261121T031500Z-my_mission_.._x"


def test_explicit_run_dir(tmp_path: Path, clock: FakeClock, logs: LogCapture) -> None:
    target = tmp_path / "here"
    rec = create(tmp_path / "unused", clock, run_dir=target)
    assert rec.run_dir == target and (target / "flight.csv").is_file()
    rec.close()
    assert not (tmp_path / "unused").exists()


# ---------------------------------------------------------------------------------------------
# Rows


def test_rows_round_trip_with_types(tmp_path: Path, clock: FakeClock, logs: LogCapture) -> None:
    rec = create(tmp_path, clock)
    rec.record(make_row(clock(), mode='HOLD, "odd"', armed=False, x_m=1.23456, yaw_rad=-3.1))
    rec.record(make_row(clock() + 0.02, cross_track_m=math.nan, pwm1_us=1999, link_ok=False))
    rec.close()
    assert rec.run_dir is not None
    rows = read_flight_csv(rec.run_dir / "flight.csv")
    assert len(rows) == 2
    assert rows[0]["mode"] == 'HOLD, "odd"' and rows[0]["armed"] is False
    assert rows[0]["x_m"] == pytest.approx(1.235, abs=1e-9)  # 1 mm resolution
    assert rows[0]["yaw_rad"] == pytest.approx(-3.1)
    assert rows[0]["target_index"] == 1 and isinstance(rows[0]["target_index"], int)
    assert math.isnan(float(rows[1]["cross_track_m"]))
    assert rows[1]["pwm1_us"] == 1999 and rows[1]["link_ok"] is False


def test_slip_columns_round_trip(tmp_path: Path, clock: FakeClock, logs: LogCapture) -> None:
    rec = create(tmp_path, clock)
    rec.record(make_row(clock(), slip_vx_frac=0.61234, slip_vy_frac=0.5, slip_w_frac=0.75))
    rec.record(make_row(clock() + 0.02))  # a writer that knows nothing of slip: nan
    rec.close()
    assert rec.run_dir is not None
    slip = ("slip_vx_frac", "slip_vy_frac", "slip_w_frac")
    assert COLUMNS[-5:-2] == slip
    assert "slip_vx_frac" in CSV_COMMENT and "v2" in CSV_COMMENT
    rows = read_flight_csv(rec.run_dir / "flight.csv")
    assert rows[0]["slip_vx_frac"] == pytest.approx(0.61234)
    assert rows[0]["slip_vy_frac"] == pytest.approx(0.5)
    assert rows[0]["slip_w_frac"] == pytest.approx(0.75)
    assert all(math.isnan(float(rows[1][c])) for c in slip)


def test_the_motion_mode_column_round_trips(
    tmp_path: Path, clock: FakeClock, logs: LogCapture
) -> None:
    rec = create(tmp_path, clock)
    rec.record(make_row(clock(), motion_mode="roll"))
    rec.record(make_row(clock() + 0.02, motion_mode="scroll"))
    rec.record(make_row(clock() + 0.04))  # a writer that knows nothing of it: empty
    rec.close()
    assert rec.run_dir is not None
    assert COLUMNS[-2] == "motion_mode" and "motion_mode" in CSV_COMMENT
    rows = read_flight_csv(rec.run_dir / "flight.csv")
    assert [r["motion_mode"] for r in rows] == ["roll", "scroll", ""]


def test_the_medium_column_round_trips(tmp_path: Path, clock: FakeClock, logs: LogCapture) -> None:
    rec = create(tmp_path, clock)
    rec.record(make_row(clock(), medium="water"))
    rec.record(make_row(clock() + 0.02))  # no media map: empty
    rec.close()
    assert rec.run_dir is not None
    assert COLUMNS[-1] == "medium" and "medium: the media map's medium" in CSV_COMMENT
    rows = read_flight_csv(rec.run_dir / "flight.csv")
    assert [r["medium"] for r in rows] == ["water", ""]


def test_summary_carries_the_last_slip_estimate() -> None:
    b = SummaryBuilder("square", "roll", 4)
    assert b.build(False, None, 0).slip_vx_frac is None
    b.add(make_row(1000.0, slip_vx_frac=0.8, slip_vy_frac=0.6, slip_w_frac=0.7))
    b.add(make_row(1000.02))  # a row without the estimate (nan): the last one is kept
    s = b.build(True, None, 0)
    assert (s.slip_vx_frac, s.slip_vy_frac, s.slip_w_frac) == (0.8, 0.6, 0.7)


def test_torn_last_line_is_skipped(tmp_path: Path, clock: FakeClock, logs: LogCapture) -> None:
    rec = create(tmp_path, clock)
    for i in range(3):
        rec.record(make_row(clock() + i))
    rec.close()
    assert rec.run_dir is not None
    path = rec.run_dir / "flight.csv"
    path.write_text(path.read_text() + "1.0,2.0,3")  # power lost mid-row
    assert len(read_flight_csv(path)) == 3


def test_bad_row_is_skipped_not_raised(tmp_path: Path, clock: FakeClock, logs: LogCapture) -> None:
    rec = create(tmp_path, clock)
    rec.record(make_row(clock(), target_index=None))
    rec.record(make_row(clock()))
    rec.close()
    assert rec.rows_written == 1 and not rec.degraded
    assert len(logs.events("recorder_bad_row")) == 1


# ---------------------------------------------------------------------------------------------
# Incremental flush


def test_rows_reach_the_disk_every_flush_interval_while_open(
    tmp_path: Path, clock: FakeClock, logs: LogCapture
) -> None:
    cfg = RecorderConfig(flush_interval_s=0.5)
    rec = create(tmp_path, clock, cfg)
    assert rec.run_dir is not None
    path = rec.run_dir / "flight.csv"
    step_s = 1.0 / 64  # ~50 Hz, exact in binary so the schedule is deterministic
    per_flush = 32  # rows in one 0.5 s interval
    on_disk: list[int] = []
    for i in range(4 * per_flush):  # 2 s of rows
        clock.advance(step_s)
        rec.record(make_row(clock(), target_index=i))
        on_disk.append(len(read_flight_csv(path)))
    # buffered between flushes (nothing reaches the disk at once) ...
    assert on_disk[10] == 0
    # ... but never more than one interval behind
    assert max(i + 1 - n for i, n in enumerate(on_disk)) < per_flush
    # a flush every 0.5 s writes everything recorded so far
    flush_points = [i for i in range(len(on_disk)) if on_disk[i] > (on_disk[i - 1] if i else 0)]
    assert flush_points == [per_flush - 1, 2 * per_flush - 1, 3 * per_flush - 1, 4 * per_flush - 1]
    assert all(on_disk[i] == i + 1 for i in flush_points)
    for _ in range(5):
        clock.advance(step_s)
        rec.record(make_row(clock(), target_index=len(on_disk)))
        on_disk.append(len(read_flight_csv(path)))
    assert on_disk[-1] == 4 * per_flush
    # a periodic maybe_flush() gets the tail out when steps stop
    clock.advance(0.6)
    rec.maybe_flush()
    rows = read_flight_csv(path)
    assert [r["target_index"] for r in rows] == list(range(4 * 32 + 5))
    rec.close()


def test_finish_writes_summary_atomically(
    tmp_path: Path, clock: FakeClock, logs: LogCapture
) -> None:
    rec = create(tmp_path, clock)
    b = SummaryBuilder("square", "roll", 4)
    for i in range(5):
        row = make_row(clock() + i * 0.02)
        rec.record(row)
        b.add(row)
    summary = b.build(False, "link_lost", 4)
    rec.finish(summary)
    rec.finish(summary)  # idempotent
    assert rec.run_dir is not None
    assert sorted(p.name for p in rec.run_dir.iterdir()) == [
        "config.yaml",
        "events.jsonl",
        "flight.csv",
        "mission.yaml",
        "summary.json",
    ]
    data = json.loads((rec.run_dir / "summary.json").read_text())
    assert data["fault"] == "link_lost" and data["exit_code"] == 4 and data["rows"] == 5
    assert len(read_flight_csv(rec.run_dir / "flight.csv")) == 5
    assert logging_setup.events_file_path() is None  # detached at the end


# ---------------------------------------------------------------------------------------------
# Write failures (tests may run as root: use failures root cannot bypass)


def dev_full_for(name: str):  # type: ignore[no-untyped-def]
    """An opener sending one file to /dev/full (ENOSPC on write-back, even for root)."""

    def opener(path: Path, mode: str) -> IO[str]:
        if path.name == name:
            return open("/dev/full", mode, encoding="utf-8")
        return default_opener(path, mode)

    return opener


def test_disk_full_mid_run_degrades_once_and_never_raises(
    tmp_path: Path, clock: FakeClock, logs: LogCapture
) -> None:
    opened: list[IO[str]] = []

    def opener(path: Path, mode: str) -> IO[str]:
        fh = default_opener(path, mode)
        opened.append(fh)
        return fh

    rec = create(tmp_path, clock, opener=opener)
    csv_fh = next(fh for fh in opened if getattr(fh, "name", "").endswith("flight.csv"))
    for _ in range(30):
        clock.advance(0.02)
        rec.record(make_row(clock()))
    assert not rec.degraded
    # the disk fills up under the open file: point its descriptor at /dev/full
    full = os.open("/dev/full", os.O_WRONLY)
    os.dup2(full, csv_fh.fileno())
    os.close(full)
    for _ in range(200):  # 4 s more of control steps: must not raise
        clock.advance(0.02)
        rec.record(make_row(clock()))
    rec.maybe_flush()
    assert rec.degraded
    b = SummaryBuilder("square", "roll", 4)
    rec.finish(b.build(False, None, 0))
    degraded = logs.events("record_cut")
    assert len(degraded) == 1
    assert degraded[0]["errno"] == errno.ENOSPC
    assert str(degraded[0]["path"]).endswith("flight.csv")
    assert "record_cut" in logs.console.getvalue()
    # the summary is still written (its space was reserved) and says the record was cut
    assert rec.run_dir is not None
    summary = json.loads((rec.run_dir / "summary.json").read_text())
    assert summary["record_cut_files"] == ["flight.csv"]
    assert summary["record_cut_at_s"] is not None
    assert not (rec.run_dir / RESERVE_FILE).exists()


def test_card_full_mid_flight_summary_says_from_when(
    tmp_path: Path, clock: FakeClock, logs: LogCapture
) -> None:
    rec = create(tmp_path, clock, opener=FullAfter(20_000))
    assert rec.run_dir is not None
    reserve = rec.run_dir / RESERVE_FILE
    assert reserve.stat().st_size == SUMMARY_RESERVE_BYTES  # held from the start
    said: list[str] = []
    rec.on_cut = said.append
    b = SummaryBuilder("square", "roll", 4)
    for _ in range(500):  # 10 s of steps at 50 Hz; the card fills after ~60 rows
        clock.advance(0.02)
        row = make_row(clock())
        b.add(row)
        rec.record(row)
    assert rec.degraded and 0 < rec.rows_written < 500
    rec.finish(b.build(True, None, 0))
    (event,) = logs.events("record_cut")
    assert event["level"] == "warning"
    assert event["file"] == "flight.csv" and event["errno"] == errno.ENOSPC
    assert len(said) == 1 and "flight.csv" in said[0] and "ENOSPC" in said[0]
    summary = json.loads((rec.run_dir / "summary.json").read_text())
    assert summary["completed"] is True  # the flight was fine; its record was not
    # the record is missing from the step that failed: flight time of the last row written
    rows = read_flight_csv(rec.run_dir / "flight.csv")
    written_s = float(rows[-1]["t_boot_s"]) - float(rows[0]["t_boot_s"])  # type: ignore[arg-type]
    assert written_s <= summary["record_cut_at_s"] <= written_s + 0.1
    assert summary["record_cut_at_s"] < summary["duration_s"]
    assert summary["record_cut_files"] == ["flight.csv"]
    assert not reserve.exists()


def test_summary_of_a_whole_record_has_no_cut(tmp_path: Path, clock: FakeClock) -> None:
    rec = create(tmp_path, clock)
    assert rec.run_dir is not None and (rec.run_dir / RESERVE_FILE).exists()
    rec.record(make_row(clock()))
    rec.finish(SummaryBuilder("square", "roll", 4).build(True, None, 0))
    summary = json.loads((rec.run_dir / "summary.json").read_text())
    assert summary["record_cut_at_s"] is None and summary["record_cut_files"] == []
    assert not (rec.run_dir / RESERVE_FILE).exists()


def test_disk_full_at_start_continue_mode(
    tmp_path: Path, clock: FakeClock, logs: LogCapture
) -> None:
    rec = create(tmp_path, clock, opener=dev_full_for("flight.csv"))
    assert rec.degraded
    for _ in range(50):
        clock.advance(0.02)
        rec.record(make_row(clock()))
    rec.finish(SummaryBuilder("square", "roll", 4).build(True, None, 0))
    (event,) = logs.events("record_cut")
    assert event["errno"] == errno.ENOSPC and event["stage"] == "create"


def test_disk_full_at_start_refuse_mode_raises(
    tmp_path: Path, clock: FakeClock, logs: LogCapture
) -> None:
    cfg = RecorderConfig(on_write_error="refuse")
    with pytest.raises(RecorderUnavailable) as info:
        create(tmp_path, clock, cfg, opener=dev_full_for("config.yaml"))
    assert info.value.errno == errno.ENOSPC
    assert "config.yaml" in str(info.value) and "on_write_error" in str(info.value)
    assert logging_setup.events_file_path() is None


def test_unwritable_run_root_refuse_and_continue(
    tmp_path: Path, clock: FakeClock, logs: LogCapture
) -> None:
    blocker = tmp_path / "not_a_dir"
    blocker.write_text("a file where the run root should be")
    root = blocker / "runs"  # ENOTDIR for everyone, root included
    with pytest.raises(RecorderUnavailable) as info:
        create(root, clock, RecorderConfig(on_write_error="refuse"))
    assert info.value.errno == errno.ENOTDIR
    assert str(blocker) in str(info.value)
    rec = create(root, clock, RecorderConfig(on_write_error="continue"))
    assert rec.degraded and rec.run_dir is None
    rec.record(make_row(clock()))
    rec.finish(SummaryBuilder().build(False, None, 0))
    assert len(logs.events("record_cut")) == 1


def test_chmod_read_only_run_root(tmp_path: Path, clock: FakeClock, logs: LogCapture) -> None:
    root = tmp_path / "ro"
    root.mkdir()
    root.chmod(0o500)
    try:
        if os.geteuid() == 0:
            # root ignores mode bits: the directory really is writable for it
            rec = create(root, clock, RecorderConfig(on_write_error="refuse"))
            assert not rec.degraded
            rec.close()
        else:
            with pytest.raises(RecorderUnavailable) as info:
                create(root, clock, RecorderConfig(on_write_error="refuse"))
            assert info.value.errno == errno.EACCES
    finally:
        root.chmod(0o700)


def test_record_after_close_is_ignored(tmp_path: Path, clock: FakeClock, logs: LogCapture) -> None:
    rec = create(tmp_path, clock)
    rec.close()
    rec.record(make_row(clock()))
    assert rec.rows_written == 0


def test_nan_row_helper() -> None:
    row = replace(nan_row(mode="X"), x_m=1.0)
    assert row.mode == "X" and row.x_m == 1.0 and math.isnan(row.y_m)


def test_every_file_cut_still_one_warning(
    tmp_path: Path, clock: FakeClock, logs: LogCapture
) -> None:
    """events.jsonl and link.tlog failing after flight.csv: one record_cut warning, every
    file named in the summary, no events_file_degraded."""
    rec = create(tmp_path, clock, opener=FullAfter(5_000))
    assert rec.run_dir is not None
    said: list[str] = []
    rec.on_cut = said.append
    b = SummaryBuilder("square", "roll", 4)
    for _ in range(100):
        clock.advance(0.02)
        row = make_row(clock())
        b.add(row)
        rec.record(row)
    assert rec.degraded
    rec.cut(rec.run_dir / "link.tlog", OSError(errno.ENOSPC, "No space left on device"))
    rec._events_cut(str(rec.run_dir / "events.jsonl"), OSError(errno.ENOSPC, "full"))
    rec.finish(b.build(True, None, 0))
    assert len(logs.events("record_cut")) == 1 and len(said) == 1
    assert logs.events("events_file_degraded") == []
    summary = json.loads((rec.run_dir / "summary.json").read_text())
    assert summary["record_cut_files"] == ["flight.csv", "link.tlog", "events.jsonl"]


def test_events_file_failure_is_the_record_cut(tmp_path: Path, clock: FakeClock) -> None:
    """The events tee's write error reaches the recorder (not events_file_degraded)."""
    console = io.StringIO()
    logging_setup.configure_logging(tty=False, stream=console, clock=clock)
    rec = create(tmp_path, clock)
    assert rec.run_dir is not None
    full = os.open("/dev/full", os.O_WRONLY)  # the events file's disk fills up
    sink = logging_setup._TEE.run
    assert sink is not None
    os.dup2(full, sink.stream.fileno())
    os.close(full)
    for _ in range(200):  # enough events to overflow the stream's buffer
        rec.record(make_row(clock()))
        structlog.get_logger("t").info("tick", payload="x" * 100)
    rec.finish(SummaryBuilder("square", "roll", 4).build(True, None, 0))
    text = console.getvalue()
    assert text.count("event=record_cut ") == 1 and "events_file_degraded" not in text
    summary = json.loads((rec.run_dir / "summary.json").read_text())
    assert summary["record_cut_files"] == ["events.jsonl"]
    assert not rec.degraded  # flight.csv kept going


def test_a_row_with_a_cell_that_does_not_parse_is_skipped_and_unknown_columns_are_numbers(
    tmp_path: Path,
) -> None:
    """Each column's reader is chosen once per file: an unknown column is read as a number,
    a row whose cell is not one (or a torn last line) is left out, the others kept."""
    path = tmp_path / "flight.csv"
    path.write_text(
        "# comment\n"
        "t_boot_s,armed,target_index,mode,newer_col\n"
        "1.5,1,3,AUTO,0.25\n"
        "2.0,0,x,HOLD,1\n"
        "2.5,false,4.0,MANUAL,2\n"
        "3.0,1,5,AU",
        encoding="utf-8",
    )
    rows = read_flight_csv(path)
    assert rows == [
        {"t_boot_s": 1.5, "armed": True, "target_index": 3, "mode": "AUTO", "newer_col": 0.25},
        {"t_boot_s": 2.5, "armed": False, "target_index": 4, "mode": "MANUAL", "newer_col": 2.0},
    ]
    assert isinstance(rows[1]["target_index"], int)
