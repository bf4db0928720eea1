"""Plots rendered from a recorded run directory (written through the real RunRecorder)."""

from __future__ import annotations

import dataclasses
import itertools
import struct
from pathlib import Path

import matplotlib.image as mpimg
import matplotlib.pyplot as plt
import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from helixd.base.plan import MissionFrameKind
from helixd.cli import runs as command
from helixd.mission.model import WaypointSpec
from helixd.mission.resume import RunInputs
from helixd.recorder.events import read_events
from helixd.recorder.outcome import CREW_COLOR
from helixd.recorder.plots import (
    OVERVIEW_SIZE_PX,
    PANEL_FILES,
    PANEL_SIZE_PX,
    _draw_driven,
    _panel_figure,
    distance_along_m,
    draw_cross_track_along,
    position_legend,
    render_run,
    sparse_label_mask,
    waypoint_labels,
)
from helixd.recorder.run_data import (
    AUTOPILOT_AXIS_LABEL,
    PlotError,
    arrival_mark,
    autopilot_axis,
    axis_labels,
    load_run,
)
from helixd.recorder.summary import Arrival, RunSummary
from tests.support.recorder_runs import SQUARE, synth_run

pytestmark = pytest.mark.usefixtures("reset_logging")

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


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
    assert [i for i, _ in data.arrivals] == ["1", "2"]  # 40 s: two sides flown (from 1)
    assert all(0.0 < t < 40.0 for _, t in data.arrivals)
    assert data.fault == "stall"
    fallback = next(e for e in read_events(run_dir / "events.jsonl") if e["event"] == "fallback")
    assert data.fault_t_s == pytest.approx(fallback["t_mono_s"] - data.cols["t_mono_s"][0])
    assert data.fault_t_s == pytest.approx(40.0, abs=0.06)


def test_via_points_are_not_numbered_as_the_operators_waypoints(tmp_path: Path) -> None:
    """A planned route's via points are drawn as such; the operator's waypoints keep their
    numbers from 1 (the plots once renumbered them 6, 7, 11)."""
    run_dir, _ = synth_run(tmp_path)
    (run_dir / "mission.yaml").write_text(
        "name: square\nmode: roll\nframe: start\nwaypoints:\n"
        "- {x: 5.0, y: 0.0, via: true}\n- {x: 10.0, y: 0.0}\n- {x: 10.0, y: 5.0, via: true}\n"
        "- {x: 10.0, y: 10.0}\n- {x: 0.0, y: 10.0}\n",
        encoding="utf-8",
    )
    data = load_run(run_dir)
    assert data.labels == ["", "1", "", "2", "3"]
    texts = [
        t for t, _ in waypoint_labels([(w[0], w[1]) for w in data.waypoints], labels=data.labels)
    ]
    assert texts == ["1", "2", "3"]
    assert len(render_run(run_dir)) == len(PANEL_FILES) + 1


def test_a_resumed_runs_planned_path_starts_on_the_interrupted_leg(tmp_path: Path) -> None:
    """Not where the rover stood when the resumed run started: the approach to the leg is no
    planned path; and the waypoints continue the whole mission's numbers."""
    run_dir, _ = synth_run(tmp_path)
    (run_dir / "mission.yaml").write_text(
        "name: lane\nmode: roll\nframe: local_ned\nwaypoints:\n"
        "- {north: 12.0, east: 6.0}\n- {north: 12.0, east: 12.0}\n",
        encoding="utf-8",
    )
    inputs = RunInputs(
        mission_sha256="a",
        config_sha256="b",
        root_mission_sha256="c",
        frame=MissionFrameKind.LOCAL_NED,
        index_offset=2,
        waypoints_total=4,
        leg_start=WaypointSpec(north=6.0, east=6.0),
        operator_offset=2,
        operator_total=4,
    )
    (run_dir / "inputs.json").write_text(inputs.to_json(), encoding="utf-8")
    data = load_run(run_dir)
    assert data.path_start == (6.0, 6.0)  # x east, y north: the waypoint before the first
    assert data.labels == ["3", "4"]


def test_fault_is_drawn_in_red(tmp_path: Path) -> None:
    run_dir, _ = synth_run(tmp_path, fault_at_s=40.0)
    render_run(run_dir)
    for name in PANEL_FILES.values():
        assert red_pixels(run_dir / "plots" / name) > 100, name


def test_a_crews_ending_and_its_pauses_are_not_drawn_as_a_fault(tmp_path: Path) -> None:
    faulted, _ = synth_run(tmp_path / "f", fault_at_s=40.0)
    crew, _ = synth_run(tmp_path / "c", fault_at_s=40.0, fault_cause="handover", pause_s=(10, 15))
    data = load_run(crew)
    assert data.end_color == CREW_COLOR and data.fault_label().startswith("crew: handover")
    assert len(data.pauses) == 1
    assert data.pauses[0] == pytest.approx((10.0, 15.0), abs=0.1)
    render_run(faulted)
    render_run(crew)
    for name in PANEL_FILES.values():
        assert red_pixels(crew / "plots" / name) < red_pixels(faulted / "plots" / name) / 4, name


def test_run_without_mission_file_still_plots(tmp_path: Path) -> None:
    run_dir, _ = synth_run(tmp_path)
    (run_dir / "mission.yaml").unlink()
    data = load_run(run_dir)
    assert data.waypoints == [] and "planned path unavailable" in data.notes
    assert len(render_run(run_dir)) == len(PANEL_FILES) + 1


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
    assert len(listed) == len(PANEL_FILES) + 1 and all(
        p.parent == out_dir and p.is_file() for p in listed
    )
    empty = tmp_path / "empty"
    empty.mkdir()
    result = runner.invoke(app, ["plot", str(empty)])
    assert result.exit_code == 2
    assert "not a helixd run directory" in result.output or "is this" in result.output


def test_time_axis_is_the_autopilot_clock_with_the_wall_clock_beside_it(tmp_path: Path) -> None:
    run_dir, _ = synth_run(tmp_path, fault_at_s=40.0, speedup=4.0)
    data = load_run(run_dir)
    assert data.on_autopilot_clock and data.time_label == AUTOPILOT_AXIS_LABEL
    assert data.t_s[-1] == pytest.approx(4.0 * data.wall_s[-1])
    # arrivals and the fault sit on the autopilot axis: 40 s of wall time is 160 s autopilot
    assert data.fault_t_s == pytest.approx(160.0, abs=0.3)
    assert all(0.0 < t < 160.0 for _, t in data.arrivals)
    # the secondary (wall) axis maps both ways, also beyond the recorded span
    assert data.wall_at(np.array([80.0, 200.0])) == pytest.approx([20.0, 50.0], abs=0.05)
    assert data.axis_at_wall(np.array([20.0, -1.0])) == pytest.approx([80.0, -4.0], abs=0.2)
    render_run(run_dir)  # and it renders


def test_autopilot_axis_bridges_a_reboot_and_falls_back_to_wall_time() -> None:
    mono = np.array([10.0, 10.5, 11.0, 11.5, 12.0])
    boot = np.array([50.0, 52.0, np.nan, 1.0, 3.0])  # NaN, then the autopilot rebooted
    axis = autopilot_axis(boot, mono)
    assert axis is not None
    assert list(axis) == pytest.approx([0.0, 2.0, 2.5, 3.0, 5.0])
    assert bool(np.all(np.diff(axis) >= 0))
    assert autopilot_axis(np.full(5, np.nan), mono) is None


def test_wall_clock_axis_when_no_autopilot_time_was_recorded(tmp_path: Path) -> None:
    (tmp_path / "flight.csv").write_text("# c\nt_mono_s,x_m,y_m\n5.0,0,0\n6.0,1,0\n7.5,2,0\n")
    data = load_run(tmp_path)
    assert not data.on_autopilot_clock and "wall time" in data.time_label
    assert list(data.t_s) == pytest.approx([0.0, 1.0, 2.5])


def test_waypoint_labels_are_sparse_on_time_axes() -> None:
    times = [10.0 + 2.0 * i for i in range(25)]  # 25 arrivals, 2 s apart on a 100 s axis
    mask = sparse_label_mask(times, 100.0, 0.06)
    labelled = [t for t, m in zip(times, mask, strict=True) if m]
    assert labelled[0] == 10.0
    assert all(b - a >= 6.0 for a, b in itertools.pairwise(labelled))
    assert 7 <= len(labelled) <= 9
    assert all(sparse_label_mask([1.0, 50.0, 99.0], 100.0, 0.06))  # far apart: all labelled


def test_coincident_waypoints_share_one_label() -> None:
    pts = [(4.0, 2.0), (3.9, 2.5), (2.0, 4.0), (4.0 + 1e-9, 2.0)]
    assert [t for t, _ in waypoint_labels(pts)] == ["1,4", "2", "3"]  # numbered from 1


def test_many_waypoint_labels_do_not_overlap_in_the_rendered_figure(tmp_path: Path) -> None:
    run_dir, _ = synth_run(tmp_path)
    data = load_run(run_dir)
    span = float(data.t_s[-1])
    data.arrivals = [(str(i + 1), span * (0.3 + 0.025 * i)) for i in range(25)]  # a circle
    fig = _panel_figure(data, "e")
    fig.canvas.draw()  # type: ignore[no-untyped-call]
    ax = fig.axes[0]
    boxes = [t.get_window_extent() for t in ax.texts if t.get_text().startswith(" WP")]
    assert 5 <= len(boxes) < 25
    for a, b in itertools.pairwise(boxes):
        assert a.x1 <= b.x0, "waypoint labels overlap"
    # the legend sits outside the data area
    legend = ax.get_legend()
    assert legend is not None
    assert legend.get_window_extent().x0 >= ax.get_window_extent().x1


def test_distance_along_the_path_ignores_jitter_and_bad_poses() -> None:
    x = np.array([0.0, 0.05, 0.0, 1.0, np.nan, 2.0, 2.0, 5.0])
    y = np.array([0.0, 0.0, 0.05, 0.0, 0.0, 0.0, 0.0, 4.0])
    fresh = np.array([True, True, True, True, True, True, False, True])
    d = distance_along_m(x, y, fresh)
    # jitter under 0.1 m adds nothing; the NaN and the stale rows are NaN and skipped
    expected = [0.0, 0.0, 0.0, 1.0, np.nan, 2.0, np.nan, 7.0]
    np.testing.assert_allclose(d, expected, equal_nan=True)
    assert np.isnan(distance_along_m(np.array([np.nan]), np.array([0.0]))).all()


def test_cross_track_along_the_path_panel(tmp_path: Path) -> None:
    """Panel (f): the cross-track curve against distance, one arrival marker per waypoint."""
    from matplotlib.figure import Figure

    run_dir, _ = synth_run(tmp_path, fault_at_s=40.0)
    data = load_run(run_dir)
    fig = Figure()
    ax = fig.add_subplot()
    draw_cross_track_along(ax, data)
    assert ax.get_xlabel() == "distance travelled along the path (m)"
    curve = ax.get_lines()[0]
    along, xt = np.asarray(curve.get_xdata()), np.asarray(curve.get_ydata())
    cols = data.cols
    ok = np.isfinite(np.asarray(cols["cross_track_m"], dtype=float))
    assert xt.size == int(ok.sum()) > 10
    assert np.all(np.diff(along) >= 0.0) and along[0] == 0.0
    # the distance axis spans the path driven (two 10 m sides before the fault at 40 s)
    assert 15.0 < float(along[-1]) < 35.0
    assert "rms" in str(curve.get_label())
    # arrival markers (dotted, grey) sit at increasing distances inside the curve
    verticals = [
        float(np.asarray(line.get_xdata())[0])
        for line in ax.get_lines()[1:]
        if line.get_linestyle() == ":"
    ]
    assert len(verticals) == len(data.arrivals) == 2
    assert verticals == sorted(verticals) and 0.0 < verticals[0] < float(along[-1])
    render_run(run_dir)
    png = run_dir / "plots" / PANEL_FILES["f"]
    assert png_size(png) == PANEL_SIZE_PX and red_pixels(png) > 100  # the fault, in red


def test_a_surveys_waypoint_labels_are_moved_clear_of_each_other() -> None:
    """Before: on the pond survey's plan plot the numbers of neighbouring transect ends
    printed over each other. Labels go to the outer side of each turn, every other one
    farther out, and a finished figure moves any that still collide."""
    from matplotlib.figure import Figure

    from helixd.recorder.plots import (
        declutter_waypoint_labels,
        label_offsets_pt,
        label_waypoint,
    )

    # a boustrophedon: 24 transects 10 m apart, 300 m long (the pond-with-island survey)
    path: list[tuple[float, float]] = []
    for i in range(24):
        ends = [(10.0 * i, 0.0), (10.0 * i, -300.0)]
        path += ends if i % 2 == 0 else ends[::-1]
    offsets = label_offsets_pt(path)
    assert offsets[1][1] < 0 and offsets[2][1] < 0 < offsets[3][1]  # below / above the turns
    assert offsets[1][0] < 0 < offsets[2][0]  # the two ends of a turn: outward, apart
    fig = Figure(figsize=(10, 7.5), dpi=100, layout="constrained")
    ax = fig.subplots()
    ax.plot([p[0] for p in path], [p[1] for p in path], "-")
    for i, (xy, off) in enumerate(zip(path, offsets, strict=True)):
        label_waypoint(ax, str(i + 1), xy, off, fontsize=9, weight="bold")
    ax.set_aspect("equal")
    declutter_waypoint_labels(fig)
    boxes = [t.get_window_extent() for t in ax.texts]
    assert len(boxes) == 48
    clashes = [
        (i, j) for i, j in itertools.combinations(range(48), 2) if boxes[i].overlaps(boxes[j])
    ]
    assert clashes == []


def test_the_trajectory_axes_say_what_x_and_y_are_in_the_missions_frame(tmp_path: Path) -> None:
    """Before: a global mission's plot said "x (m)"/"y (m)", no north/east, no origin."""
    assert axis_labels(MissionFrameKind.GLOBAL, (53.52325, -113.52632)) == (
        "x, east of the EKF origin 53.523250°, -113.526320° (m)",
        "y, north of the EKF origin 53.523250°, -113.526320° (m)",
    )
    assert axis_labels(MissionFrameKind.LOCAL_NED, None)[1] == "y, north of the EKF origin (m)"
    run_dir, _ = synth_run(tmp_path)
    data = load_run(run_dir)
    assert data.axis_labels == axis_labels(
        load_mission_frame(run_dir), data.summary.origin_latlon_deg if data.summary else None
    )
    fig = _panel_figure(data, "a")
    assert (fig.axes[0].get_xlabel(), fig.axes[0].get_ylabel()) == data.axis_labels


def load_mission_frame(run_dir: Path) -> MissionFrameKind:
    from helixd.mission.model import load_mission

    return load_mission(run_dir / "mission.yaml").frame


def test_an_item_a_jump_flies_again_is_labelled_once() -> None:
    # item numbers of a DO_JUMP mission: 1, 2, 1, 2, 5 (item 5 returns to item 1's place)
    points = [(0.0, 0.0), (5.0, 0.0), (0.0, 0.0), (5.0, 0.0), (0.0, 0.0)]
    got = waypoint_labels(points, labels=["1", "2", "1", "2", "5"])
    assert got == [("1,5", (0.0, 0.0)), ("2", (5.0, 0.0))]


def test_time_markers_of_a_jump_mission_say_the_lap(tmp_path: Path) -> None:
    """Each lap's arrival at an item a DO_JUMP repeats is its own marker: 'WP1 lap 2/2', as the
    log and the ground station say 'reached WP 1/3 (lap 2 of 2)'."""
    run_dir, _ = synth_run(tmp_path)
    path = run_dir / "summary.json"
    summary = RunSummary.from_json(path.read_text(encoding="utf-8"))
    laps = ["lap 1 of 2", "lap 1 of 2", "lap 2 of 2", "lap 2 of 2"]
    arrivals = [
        a.model_copy(update={"number": 1 + k % 2, "lap": lap})
        for k, (a, lap) in enumerate(zip(summary.arrivals, laps, strict=False))
    ]
    path.write_text(summary.model_copy(update={"arrivals": tuple(arrivals)}).to_json(), "utf-8")
    marks = [label for label, _ in load_run(run_dir).arrivals]
    assert marks == ["1 lap 1/2", "2 lap 1/2", "1 lap 2/2", "2 lap 2/2"][: len(marks)]
    assert len(marks) >= 3
    plain = Arrival(index=4, t_boot_s=1.0, error_m=0.1)
    assert arrival_mark(plain) == "5"
    assert arrival_mark(plain.model_copy(update={"number": 3, "lap": "lap 7"})) == "3 lap 7"


def test_the_position_panel_says_east_and_north_as_the_trajectory_does() -> None:
    """A global mission's x and y over time read 'x, east (m)', 'y, north (m)', not a bare
    'x (m)' beside a trajectory that says east and north of the EKF origin."""
    origin = (53.52325, -113.52632)
    assert position_legend(axis_labels(MissionFrameKind.GLOBAL, origin)) == (
        "x, east (m)",
        "y, north (m)",
    )
    assert position_legend(axis_labels(MissionFrameKind.START, None)) == (
        "x, forward (m)",
        "y, left (m)",
    )
    assert position_legend(axis_labels(None, None)) == ("x (m)", "y (m)")


def test_the_driven_path_is_coloured_by_motion_mode_where_it_changed(tmp_path: Path) -> None:
    run_dir, _ = synth_run(tmp_path)
    data = load_run(run_dir)
    n = len(data.col("x_m"))
    modes = np.array(["roll"] * (n // 3) + ["scroll"] * (n // 3), dtype=object)
    modes = np.concatenate([modes, np.array(["roll"] * (n - len(modes)), dtype=object)])
    changed = dataclasses.replace(data, cols={**data.cols, "motion_mode": modes})
    fig, ax = plt.subplots()
    _draw_driven(ax, changed, changed.col("x_m"), changed.col("y_m"))
    labels = [line.get_label() for line in ax.get_lines()]
    assert len(ax.get_lines()) == 3  # roll, scroll, roll
    assert labels.count("driven in roll") == 1 and labels.count("driven in scroll") == 1
    fig2, ax2 = plt.subplots()  # none recorded: one line
    _draw_driven(ax2, data, data.col("x_m"), data.col("y_m"))
    assert [line.get_label() for line in ax2.get_lines()] == ["driven"]
    one = dataclasses.replace(data, cols={**data.cols, "motion_mode": np.array(["scroll"] * n)})
    fig3, ax3 = plt.subplots()  # one mode: the legend still says which
    _draw_driven(ax3, one, one.col("x_m"), one.col("y_m"))
    assert [line.get_label() for line in ax3.get_lines()] == ["driven in scroll"]
    plt.close(fig3)
    plt.close(fig)
    plt.close(fig2)
