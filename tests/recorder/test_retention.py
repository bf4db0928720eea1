"""Retention of old run directories and the free-space warning (helixd.recorder.retention)."""

from __future__ import annotations

import io
import json
from pathlib import Path

import pytest

from helixd.recorder import logging_setup
from helixd.recorder.retention import (
    RECORD_BYTES_PER_S,
    RunDir,
    check_free_space,
    plan_prune,
    prune_runs,
    record_bytes_estimate,
)

pytestmark = pytest.mark.usefixtures("reset_logging")


@pytest.fixture
def events() -> io.StringIO:
    buf = io.StringIO()
    logging_setup.configure_logging(tty=False, stream=io.StringIO(), json_file=buf)
    return buf


def logged(buf: io.StringIO, name: str) -> list[dict[str, object]]:
    out = [json.loads(ln) for ln in buf.getvalue().splitlines()]
    return [e for e in out if e["event"] == name]


def make_runs(root: Path, n: int, size: int = 1000) -> list[Path]:
    runs = []
    for i in range(n):
        d = root / f"202611{(i // 24) + 1:02d}T{i % 24:02d}0000Z-square"
        d.mkdir(parents=True)
        (d / "flight.csv").write_bytes(b"x" * size)
        runs.append(d)
    return runs


def test_plan_prune_by_count_oldest_first() -> None:
    runs = [RunDir(Path(f"2026110{i}T000000Z-m"), 10) for i in (3, 1, 2, 5, 4)]
    out = plan_prune(runs, keep_runs=3, keep_bytes=None, protected=set())
    assert [r.path.name for r in out] == ["20261101T000000Z-m", "20261102T000000Z-m"]


def test_plan_prune_by_size_skips_protected() -> None:
    runs = [RunDir(Path(f"2026110{i}T000000Z-m"), 100) for i in range(1, 6)]
    protected = {Path("20261101T000000Z-m")}
    out = plan_prune(runs, keep_runs=100, keep_bytes=250, protected=protected)
    # 500 bytes: the oldest is protected, so the next three go to come within 250
    assert [r.path.name for r in out] == [
        "20261102T000000Z-m",
        "20261103T000000Z-m",
        "20261104T000000Z-m",
    ]


def test_plan_prune_within_limits_removes_nothing() -> None:
    runs = [RunDir(Path(f"2026110{i}T000000Z-m"), 100) for i in range(1, 4)]
    assert plan_prune(runs, keep_runs=3, keep_bytes=300, protected=set()) == []


def test_prune_runs_keeps_current_and_newest_earlier(tmp_path: Path, events: io.StringIO) -> None:
    runs = make_runs(tmp_path, 6)
    other = tmp_path / "notes"  # not a run directory: never touched
    other.mkdir()
    (tmp_path / "20261101T000000Z-stray.txt").write_text("a file, not a run")
    current = runs[-1]
    removed = prune_runs(tmp_path, keep_runs=1, keep_bytes=None, current=current)
    assert removed == runs[:4]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [runs[4].name, runs[5].name, "notes", "20261101T000000Z-stray.txt"]
    )
    assert len(logged(events, "run_pruned")) == 4
    (summary,) = logged(events, "runs_pruned")
    assert summary["count"] == 4 and summary["keep_runs"] == 1


def test_prune_runs_by_size(tmp_path: Path, events: io.StringIO) -> None:
    runs = make_runs(tmp_path, 5, size=4000)
    removed = prune_runs(tmp_path, keep_runs=200, keep_bytes=9000, current=runs[-1])
    assert removed == runs[:3]
    assert [p for p in runs if p.exists()] == runs[3:]


def test_prune_runs_missing_root(tmp_path: Path) -> None:
    assert prune_runs(tmp_path / "absent", keep_runs=1, keep_bytes=None, current=None) == []


def test_free_space_warning_below_one_flight(tmp_path: Path, events: io.StringIO) -> None:
    needed = record_bytes_estimate(600.0)
    assert needed > 600 * RECORD_BYTES_PER_S

    def low(_: Path) -> tuple[int, int, int]:
        return (10**10, 10**10 - needed + 1, needed - 1)

    def plenty(_: Path) -> tuple[int, int, int]:
        return (10**10, 0, needed * 10)

    text = check_free_space(tmp_path, 600.0, disk_usage=low)
    assert text is not None and "MB free" in text and str(tmp_path) in text
    (event,) = logged(events, "disk_space_low")
    assert event["level"] == "warning" and event["needed_bytes"] == needed
    assert check_free_space(tmp_path, 600.0, disk_usage=plenty) is None
    assert len(logged(events, "disk_space_low")) == 1


def test_free_space_unreadable_is_silent(tmp_path: Path) -> None:
    def broken(_: Path) -> tuple[int, int, int]:
        raise OSError(5, "I/O error")

    assert check_free_space(tmp_path, 60.0, disk_usage=broken) is None


def test_record_estimate_without_a_duration() -> None:
    assert record_bytes_estimate(None) > record_bytes_estimate(60.0)
    assert record_bytes_estimate(float("nan")) == record_bytes_estimate(None)
