"""The plots of an amphibious run show the ground: the media map's areas
under the track, the track's legend by motion mode, a title with the modes actually flown
(not the mission file's nominal mode), the commanded speeds drawn over the measured one. A
crossing flown on the simulated clock (a water band 10..30 m north, the mission's nominal
mode SCROLL, half of it rolled), then ``helixd plot``'s figures inspected."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import pytest
from matplotlib.patches import PathPatch

from helixd.base.exitcodes import ExitCode
from helixd.base.media import MediaFrame, MediaMap, Medium
from helixd.recorder.plots import _panel_figure, render_run
from helixd.recorder.run_data import load_run
from tests.integration.test_amphibious_flight import band, geojson, mission
from tests.support.simulated import simulated_flight

pytestmark = [pytest.mark.integration, pytest.mark.usefixtures("reset_logging")]


def test_the_plots_of_a_crossing_show_the_pond_the_modes_flown_and_the_commands(
    tmp_path: Path,
) -> None:
    helixd_map = geojson(tmp_path / "water.geojson", ("water", 10.0, 30.0))
    world = MediaMap(MediaFrame.LOCAL_NED, (band(Medium.WATER, 10.0, 30.0),), Medium.HARD)
    path = mission(tmp_path / "crossing.yaml", helixd_map, 40.0)
    flown = simulated_flight(tmp_path, path, media=world, noise="low", seed=6)
    assert flown.code == ExitCode.OK, flown.log[-3000:]
    run_dir = flown.run_dir()
    data = load_run(run_dir)
    assert data.media is not None  # from the flight's media_plan event
    # the title: the modes flown by distance, not the file's "scroll"
    assert data.modes_text.startswith(("roll 5", "scroll 5", "roll 4", "scroll 4")), data.modes_text
    assert "roll" in data.modes_text and "scroll" in data.modes_text

    fig = _panel_figure(data, "a")
    ax = fig.axes[0]
    assert data.modes_text in fig.get_suptitle()
    water = [p for p in ax.patches if isinstance(p, PathPatch)]
    assert len(water) == 1 and water[0].get_zorder() < min(ln.get_zorder() for ln in ax.lines)
    # x east, y north: the band spans north 10..30
    ys = water[0].get_path().vertices[:, 1]
    assert min(ys) == pytest.approx(10.0) and max(ys) == pytest.approx(30.0)
    labels = ax.get_legend_handles_labels()[1]
    assert "water (media map)" in labels and "hard elsewhere (media map)" in labels
    assert "driven in roll" in labels and "driven in scroll" in labels
    # the view stays on the flight (the band is 60 m wide, the crossing 40 m long)
    x0, x1 = ax.get_xlim()
    assert x1 - x0 < 45.0, (x0, x1)

    fig_c = _panel_figure(data, "c")
    lines = {ln.get_label(): ln for ln in fig_c.axes[0].lines}
    measured = lines["speed measured (m/s)"]
    for cmd in ("v_x cmd (m/s)", "|v| cmd (m/s)"):
        assert lines[cmd].get_zorder() > measured.get_zorder(), cmd
    plt.close("all")
    written = render_run(run_dir, tmp_path / "plots")
    assert len(written) == 7 and all(p.stat().st_size > 10_000 for p in written)
