"""``helixd replay``: summary and event timeline of a recorded run."""

from __future__ import annotations

import io
import itertools
import math
import re
from pathlib import Path

import pytest
import structlog
import typer
from hypothesis import given
from hypothesis import strategies as st
from typer.testing import CliRunner

from helixd.cli import runs as command
from helixd.recorder import logging_setup
from helixd.recorder.clocks import ClockMap, autopilot_axis_s
from helixd.recorder.events import read_events, timeline
from helixd.recorder.rows import COLUMNS
from tests.support.recorder_runs import synth_run

pytestmark = pytest.mark.usefixtures("reset_logging")


@pytest.fixture
def app() -> typer.Typer:
    app = typer.Typer()
    command.register(app)
    return app


def test_replay_prints_summary_and_timeline(tmp_path: Path, app: typer.Typer) -> None:
    run_dir, _ = synth_run(tmp_path, fault_at_s=40.0)
    result = CliRunner().invoke(app, ["replay", str(run_dir)])
    assert result.exit_code == 0, result.output
    out = result.stdout
    assert "\x1b" not in out  # not a terminal: plain text
    assert re.search(r"result\s+NOT completed", out)
    assert re.search(r"fault\s+stall", out)
    assert re.search(r"waypoints\s+2/4", out)
    lines = out.splitlines()
    header = lines.index(next(ln for ln in lines if ln.startswith("events")))
    assert "from the first control step" in lines[header]
    assert lines[header + 1].split()[:3] == ["autopilot", "wall", "level"]
    timeline_lines = lines[header + 2 :]
    names = [ln.split()[3] for ln in timeline_lines]
    assert names[0] == "run_started"
    assert names[1:4] == ["waypoint_reached", "waypoint_reached", "fallback"]
    assert names[-1] == "run_recorded"
    fallback = next(ln for ln in timeline_lines if " fallback " in ln)
    t_ap, t_wall = (float(v) for v in fallback.split()[:2])
    assert t_wall == pytest.approx(40.0, abs=0.06)  # seconds since the first control step
    assert t_ap == pytest.approx(t_wall, abs=0.06)  # no speed-up: the clocks agree
    assert "cause=stall" in fallback and "warning" in fallback
    reached = next(ln for ln in timeline_lines if "waypoint_reached" in ln)
    assert "index=0" in reached


def test_periodic_events_only_with_all(tmp_path: Path, app: typer.Typer) -> None:
    run_dir, clock = synth_run(tmp_path)
    logging_setup.configure_logging(tty=False, stream=io.StringIO(), clock=clock)
    logging_setup.attach_events_file(run_dir / "events.jsonl")
    structlog.get_logger("t").info("progress", waypoint="4/4")
    logging_setup.detach_events_file()
    runner = CliRunner()
    plain = runner.invoke(app, ["replay", str(run_dir)]).stdout
    full = runner.invoke(app, ["replay", str(run_dir), "--all"]).stdout
    assert " progress " not in plain and " progress " in full


def test_replay_of_a_crashed_run(tmp_path: Path, app: typer.Typer) -> None:
    run_dir, _ = synth_run(tmp_path)
    (run_dir / "summary.json").unlink()
    result = CliRunner().invoke(app, ["replay", str(run_dir)])
    assert result.exit_code == 0
    assert "did not finish cleanly" in result.stdout
    assert re.search(r"flight\.csv: \d{3,} rows", result.stdout)


def test_replay_rejects_a_non_run_directory(tmp_path: Path, app: typer.Typer) -> None:
    result = CliRunner().invoke(app, ["replay", str(tmp_path / "missing")])
    assert result.exit_code == 2 and "not a directory" in result.output


def test_rich_replay_on_a_terminal(tmp_path: Path) -> None:
    run_dir, _ = synth_run(tmp_path, fault_at_s=20.0)
    out = io.StringIO()
    command.print_replay(run_dir, tty=True, out=out)
    text = out.getvalue()
    assert "helixd run result" in text and "fallback" in text and "run_started" in text
    assert "NOT completed" in text


def test_timeline_tolerates_torn_lines(tmp_path: Path) -> None:
    path = tmp_path / "events.jsonl"
    path.write_text(
        '{"event": "run_started", "t_mono_s": 10.0, "level": "info", "ts": "x"}\n'
        '{"event": "fallback", "t_mono_s": 12.5, "level": "warning", "cause": "link"}\n'
        '{"event": "torn", "t_mo'
    )
    entries = timeline(read_events(path))
    assert [(e.event, e.t_s, e.fields) for e in entries] == [
        ("run_started", 0.0, ""),
        ("fallback", 2.5, "cause=link"),
    ]


def test_replay_times_events_on_the_autopilot_clock_with_wall_time_beside(
    tmp_path: Path, app: typer.Typer
) -> None:
    run_dir, _ = synth_run(tmp_path, fault_at_s=40.0, speedup=4.0)
    out = CliRunner().invoke(app, ["replay", str(run_dir)]).stdout
    assert "the autopilot clock ran 4.00x the wall clock" in out
    fallback = next(ln for ln in out.splitlines() if " fallback " in ln)
    t_ap, t_wall = (float(v) for v in fallback.split()[:2])
    assert t_wall == pytest.approx(40.0, abs=0.06)
    assert t_ap == pytest.approx(160.0, abs=0.3)
    assert re.search(r"flight time \(autopilot clock\)\s+15\d\.\d s", out)


def test_clock_map_interpolates_and_extends_at_the_average_rate() -> None:
    cm = ClockMap([10.0, 11.0, 12.0], [100.0, 104.0, 108.0])
    assert cm.rate == pytest.approx(4.0) and cm.zero_mono_s == 10.0
    assert cm.autopilot_s(11.5) == pytest.approx(6.0)
    assert cm.autopilot_s(9.0) == pytest.approx(-4.0)  # setup, before the first step
    assert cm.autopilot_s(13.0) == pytest.approx(12.0)  # the stop, after the last
    assert cm.wall_s(9.0) == pytest.approx(-1.0)
    assert cm.autopilot_s(math.nan) is None
    empty = ClockMap([], [])
    assert not empty.has_rows and empty.autopilot_s(1.0) is None and empty.wall_s(1.0) is None
    no_ap = ClockMap([1.0, 2.0], [math.nan, math.nan])
    assert no_ap.has_rows and not no_ap.has_autopilot and no_ap.autopilot_s(1.5) is None


def test_replay_of_a_run_refused_before_flight(tmp_path: Path, app: typer.Typer) -> None:
    run_dir, _ = synth_run(tmp_path)
    (run_dir / "flight.csv").write_text("# c\n" + ",".join(COLUMNS) + "\n")  # no rows
    out = CliRunner().invoke(app, ["replay", str(run_dir)]).stdout
    assert "wall clock (s) since the run started; no control step was recorded" in out
    started = next(ln for ln in out.splitlines() if " run_started " in ln)
    assert started.split()[:2] == ["-", "0.000"]


_times = st.floats(min_value=-1e9, max_value=1e9) | st.sampled_from([math.nan, math.inf, -math.inf])


@given(st.lists(st.tuples(_times, _times), max_size=40), st.lists(_times, max_size=10))
def test_clock_map_is_total_and_monotonic_on_any_input(
    rows: list[tuple[float, float]], queries: list[float]
) -> None:
    cm = ClockMap([m for m, _ in rows], [b for _, b in rows])
    axis = autopilot_axis_s([b for _, b in rows], [m for m, _ in rows])
    if axis is not None:
        assert all(math.isfinite(a) for a in axis)
        assert all(b >= a for a, b in itertools.pairwise(axis))
    finite = sorted(q for q in queries if math.isfinite(q))
    mapped = [cm.autopilot_s(q) for q in finite]
    if cm.has_rows and cm.has_autopilot:
        values = [v for v in mapped if v is not None]
        assert len(values) == len(finite)
        assert all(b >= a - 1e-6 * max(1.0, abs(a)) for a, b in itertools.pairwise(values))
    for q in queries:
        if not math.isfinite(q):
            assert cm.autopilot_s(q) is None
