"""Plots rendered from a recorded run directory (written through the real RunRecorder)."""

from __future__ import annotations

import struct
from collections.abc import Iterator
from pathlib import Path

import matplotlib.image as mpimg
import numpy as np
import pytest
import structlog
import typer
from typer.testing import CliRunner

from helixd import logging_setup
from helixd.plots import (
    OVERVIEW_SIZE_PX,
    PANEL_FILES,
    PANEL_SIZE_PX,
    PlotError,
    load_run,
    render_run,
)
from helixd.recorder import command
from helixd.recorder.events import read_events
from tests.unit.test_recorder import SQUARE, synth_run

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(autouse=True)
def _reset_logging() -> Iterator[None]:
    yield
    logging_setup.detach_events_file()
    structlog.reset_defaults()


def png_size(path: Path) -> tuple[int, int]:
    head = path.read_bytes()[:24]
    assert head[:8] == PNG_SIGNATURE, f"{path} is not a PNG"
    assert head[12:16] == b"IHDR"
    width, height = struct.unpack(">II", head[16:24])
    return width, height


def red_pixels(path: Path) -> int:
    img = mpimg.imread(path)
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return int(np.count_nonzero((r > 0.9) & (g < 0.15) & (b < 0.15)))


def test_render_run_writes_real_pngs_of_the_expected_size(tmp_path: Path) -> None:
    run_dir, _ = synth_run(tmp_path / "runs")
    paths = render_run(run_dir, tmp_path / "out")
    assert [p.name for p in paths] == [*PANEL_FILES.values(), "overview.png"]
    for path in paths:
        expected = OVERVIEW_SIZE_PX if path.name == "overview.png" else PANEL_SIZE_PX
        assert png_size(path) == expected
        img = mpimg.imread(path)
        assert img.shape[:2] == (expected[1], expected[0])
        assert float(img[..., :3].std()) > 0.05  # something was drawn, not a blank canvas
    # clean run: nothing drawn in fault red
    for name in PANEL_FILES.values():
        assert red_pixels(tmp_path / "out" / name) == 0, name


def test_default_output_dir_is_inside_the_run(tmp_path: Path) -> None:
    run_dir, _ = synth_run(tmp_path)
    paths = render_run(run_dir)
    assert all(p.parent == run_dir / "plots" and p.is_file() for p in paths)


def test_plan_arrivals_and_fault_are_loaded(tmp_path: Path) -> None:
    run_dir, _ = synth_run(tmp_path, fault_at_s=40.0)
    data = load_run(run_dir)
    assert [(x, y) for x, y, _ in data.waypoints] == SQUARE
    assert all(tol == 1.0 for _, _, tol in data.waypoints)
    assert data.path_start == (0.0, 0.0)
    assert [i for i, _ in data.arrivals] == [0, 1]  # 40 s: two sides flown
    assert all(0.0 < t < 40.0 for _, t in data.arrivals)
    assert data.fault == "stall"
    fallback = next(e for e in read_events(run_dir / "events.jsonl") if e["event"] == "fallback")
    assert data.fault_t_s == pytest.approx(fallback["t_mono_s"] - data.cols["t_mono_s"][0])
    assert data.fault_t_s == pytest.approx(40.0, abs=0.06)


def test_fault_is_drawn_in_red(tmp_path: Path) -> None:
    run_dir, _ = synth_run(tmp_path, fault_at_s=40.0)
    render_run(run_dir)
    for name in PANEL_FILES.values():
        assert red_pixels(run_dir / "plots" / name) > 100, name


def test_run_without_mission_file_still_plots(tmp_path: Path) -> None:
    run_dir, _ = synth_run(tmp_path)
    (run_dir / "mission.yaml").unlink()
    data = load_run(run_dir)
    assert data.waypoints == [] and "planned path unavailable" in data.notes
    assert len(render_run(run_dir)) == 6


def test_nothing_to_plot(tmp_path: Path) -> None:
    with pytest.raises(PlotError, match=r"no flight\.csv"):
        load_run(tmp_path)
    (tmp_path / "flight.csv").write_text("# comment\nt_mono_s,x_m\n")
    with pytest.raises(PlotError, match="no rows"):
        render_run(tmp_path)


def test_plot_command(tmp_path: Path) -> None:
    run_dir, _ = synth_run(tmp_path / "runs")
    app = typer.Typer()
    command.register(app)
    runner = CliRunner()
    out_dir = tmp_path / "figs"
    result = runner.invoke(app, ["plot", str(run_dir), "--out", str(out_dir)])
    assert result.exit_code == 0, result.output
    listed = [Path(line) for line in result.stdout.splitlines() if line.endswith(".png")]
    assert len(listed) == 6 and all(p.parent == out_dir and p.is_file() for p in listed)
    empty = tmp_path / "empty"
    empty.mkdir()
    result = runner.invoke(app, ["plot", str(empty)])
    assert result.exit_code == 2
    assert "not a helixd run directory" in result.output or "is this" in result.output
