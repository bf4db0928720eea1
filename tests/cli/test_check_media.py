"""``check`` with a media map: each stretch's medium and mode, each change of mode, the
estimate counting the turns; the map checked at the edge."""

from __future__ import annotations

import json
import re
from pathlib import Path

import matplotlib.pyplot as plt
import pytest
import yaml
from matplotlib.patches import PathPatch

from helixd.config.root import HelixdConfig
from helixd.files.media import read_media_map
from helixd.mission.model import load_mission
from helixd.prepare.media_figure import checked_media
from helixd.recorder.plan_plots import draw_media_plan
from tests.support.cli import check_out, run_main
from tests.support.missions import mission_file
from tests.support.paths import REPO_ROOT

SURVEY = REPO_ROOT / "config" / "missions" / "pond-survey.yaml"  # global, media_map: pond


def crossing(tmp_path: Path, **extra: object) -> Path:
    """A 60 m leg north over 40 m of water (local_ned map and mission)."""
    ring = [[-30, 10], [30, 10], [30, 50], [-30, 50], [-30, 10]]  # [east, north]
    media = {
        "type": "FeatureCollection", "frame": "local_ned", "default_medium": "hard",
        "features": [{"type": "Feature", "properties": {"medium": "water"},
                      "geometry": {"type": "Polygon", "coordinates": [ring]}}],
    }  # fmt: skip
    (tmp_path / "water.geojson").write_text(json.dumps(media), encoding="utf-8")
    mission = {
        "name": "crossing", "mode": "scroll", "frame": "local_ned",
        "media_map": "water.geojson", "waypoints": [{"north": 0.0, "east": 0.0},
                                                     {"north": 60.0, "east": 0.0}],
        **extra,
    }  # fmt: skip
    return mission_file(tmp_path / "crossing.yaml", mission)


def test_a_crossing_shows_its_stretches_and_turns(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = check_out(["--mission", str(crossing(tmp_path))], capsys)
    assert "mode=roll/scroll/roll" not in out  # the modes are listed once each
    assert "mode=roll/scroll" in out
    stretches = [ln for ln in out.splitlines() if ln.startswith("stretch : ")]
    assert [ln.split()[7] for ln in stretches] == ["roll", "scroll", "roll"], out
    assert "over hard 1.0 m, water 40.0 m, hard 1.0 m" in stretches[1]  # the banks it turns on
    changes = [ln for ln in out.splitlines() if ln.startswith("change  : ")]
    assert changes == [
        "change  : roll → scroll at (0.0, 9.0) on hard: stop, turn 90° in place",
        "change  : scroll → roll at (0.0, 51.0) on hard: stop, turn 90° in place",
    ], out
    assert "3 stretches, 2 changes of mode (2 turns in place" in out
    turns = re.search(r"in (\d+) turns in place", out)
    assert turns is not None and int(turns.group(1)) >= 2, out  # the estimate counts them
    rows = [ln for ln in out.splitlines() if ln.lstrip().startswith("via → 2")]
    assert len(rows) == 2 and all("(stop)" in r for r in rows), out


def test_a_waypoints_own_mode_pins_its_leg(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = crossing(tmp_path)
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    data["waypoints"][1]["mode"] = "scroll"
    mission_file(path, data)
    out = check_out(["--mission", str(path)], capsys)
    assert "change  : " not in out
    assert "(the waypoint's own mode)" in out


def test_the_missions_media_modes_replace_the_configs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = crossing(tmp_path, media_modes={"water": "omni"})
    out = check_out(["--mission", str(path)], capsys)
    assert "change  : roll → omni at (0.0, 9.0) on hard: stop, no turn (OMNI)" in out


def test_a_missing_media_map_is_refused_naming_the_field(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = crossing(tmp_path)
    (tmp_path / "water.geojson").unlink()
    code, out, err = run_main(["check", "--mission", str(path)], capsys)
    assert code == 2, out + err
    assert "media_map: " in out + err and "water.geojson: no such file" in out + err


def test_a_bad_medium_in_the_map_is_refused_naming_the_feature(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = crossing(tmp_path)
    text = (tmp_path / "water.geojson").read_text(encoding="utf-8").replace("water", "lava")
    (tmp_path / "water.geojson").write_text(text, encoding="utf-8")
    code, out, err = run_main(["check", "--mission", str(path)], capsys)
    assert code == 2, out + err
    assert "features.0.properties.medium" in out + err and "lava" in out + err


def test_the_shipped_pond_survey_rolls_the_banks_and_scrolls_the_water(
    capsys: pytest.CaptureFixture[str],
) -> None:
    out = check_out(["--mission", str(SURVEY)], capsys)
    stretches = [ln for ln in out.splitlines() if ln.startswith("stretch : ")]
    modes = [ln.split()[7] for ln in stretches]
    assert modes == ["roll", "scroll", "roll", "scroll", "roll", "scroll", "roll"], out
    assert all("water" in ln for ln, m in zip(stretches, modes, strict=True) if m == "scroll")
    assert "6 changes of mode" in out


def gcs_crossing(tmp_path: Path, code: float) -> tuple[Path, Path]:
    """A .waypoints mission (60 m north) whose second waypoint's param4 ("Yaw") is ``code``,
    and a config with the water map in media.media_map."""
    crossing(tmp_path)  # writes water.geojson
    lat2 = 53.5 + 60.0 / 111_195.0
    rows = [
        "QGC WPL 110",
        "0\t1\t0\t16\t0\t0\t0\t0\t53.5\t-113.5\t0\t1",
        "1\t0\t3\t16\t0\t0\t0\t0\t53.5\t-113.5\t0\t1",
        f"2\t0\t3\t16\t0\t0\t0\t{code}\t{lat2:.8f}\t-113.5\t0\t1",
    ]
    mission = tmp_path / "crossing.waypoints"
    mission.write_text("\n".join(rows) + "\n", encoding="utf-8")
    config = tmp_path / "helixd.yaml"
    media = str(tmp_path / "water.geojson")
    config.write_text(
        json.dumps({"mission": {"ground_station_mode": "scroll"}, "media": {"media_map": media}}),
        encoding="utf-8",
    )
    return mission, config


def test_a_ground_station_mission_follows_the_configs_media_map(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mission, config = gcs_crossing(tmp_path, 0.0)
    out = check_out(["--config", str(config), "--mission", str(mission)], capsys)
    assert out.count("change  : ") == 2, out


def test_a_ground_station_pins_a_legs_mode_by_the_yaw_code(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mission, config = gcs_crossing(tmp_path, -2.0)  # -2: scroll the whole leg
    out = check_out(["--config", str(config), "--mission", str(mission)], capsys)
    assert "change  : " not in out
    assert "(the waypoint's own mode)" in out


def test_check_plot_draws_an_amphibious_missions_media_and_stretches(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: `check --plot` wrote nothing for a mission that follows a media map and plans
    no route around obstacles."""
    png = tmp_path / "plan.png"
    code, out, err = run_main(["check", "--mission", str(crossing(tmp_path)), "--plot", str(png)],
                              capsys)  # fmt: skip
    assert code == 0, err
    assert f"plot    : {png}" in out and "not written" not in out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    assert "Ignoring fixed" not in out + err  # the equal aspect is not fought


def test_the_media_plan_figure_shows_the_areas_and_each_stretch_by_mode(tmp_path: Path) -> None:
    path = crossing(tmp_path)
    cfg = HelixdConfig()
    msn = load_mission(path, cfg.mission)
    got = checked_media(cfg, msn, msn, read_media_map(tmp_path / "water.geojson"))
    assert got.placed is not None and got.plan is not None, got.why
    fig, ax = plt.subplots()
    draw_media_plan(ax, got.placed, got.plan, got.plan.plan.assumed_start_xy_m())
    (water,) = [p for p in ax.patches if isinstance(p, PathPatch)]
    assert water.get_label() == "water (media map)"
    labels = ax.get_legend_handles_labels()[1]
    assert "planned in roll" in labels and "planned in scroll" in labels
    assert "change of mode (turn in place)" in labels
    by_mode = {ln.get_label(): ln.get_color() for ln in ax.lines}
    assert by_mode["planned in roll"] != by_mode["planned in scroll"]
    plt.close(fig)


def pinned_survey(tmp_path: Path) -> Path:
    """The shipped pond survey with waypoint 2's leg (north across the pond) pinned to roll."""
    text = SURVEY.read_text(encoding="utf-8")
    text = text.replace(
        "../maps/pond-media.geojson", str(REPO_ROOT / "config/maps/pond-media.geojson")
    )
    first_leg = "- lat: 53.5237171\n  lon: -113.5263200\n"
    assert first_leg in text
    text = text.replace(first_leg, first_leg + "  mode: roll\n", 1)
    path = tmp_path / "pond-roll.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def stretch_rows(out: str) -> list[tuple[float, float, str, float]]:
    """(start, end, mode, metres of media listed) per stretch line."""
    rows = []
    for ln in out.splitlines():
        m = re.match(r"stretch : \d+\s+([\d.]+) →\s+([\d.]+) m  (\w+)\s+over (.*)", ln)
        if m:
            listed = sum(float(x) for x in re.findall(r"([\d.]+) m", m.group(4)))
            rows.append((float(m.group(1)), float(m.group(2)), m.group(3), listed))
    return rows


def test_each_change_of_mode_stands_between_the_stretches_it_joins(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = check_out(["--mission", str(pinned_survey(tmp_path))], capsys)
    lines = [ln for ln in out.splitlines() if ln.startswith(("stretch : ", "change  : "))]
    modes = [ln.split()[7] for ln in lines if ln.startswith("stretch")]
    assert modes == ["roll", "roll", "scroll", "roll", "scroll", "roll"], out
    for k, ln in enumerate(lines):  # a change follows the stretch it leaves, before the next
        if ln.startswith("change"):
            before, after = ln.split()[2], ln.split()[4]
            assert lines[k - 1].split()[7] == before and lines[k + 1].split()[7] == after, out
    # the pinned roll leg and the roll after it: no stop and no change between them
    assert "4 changes of mode" in out
    assert "4 via points inserted" in out


@pytest.mark.parametrize("pinned", [False, True])
def test_each_stretch_lists_the_media_over_its_whole_length(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], pinned: bool
) -> None:
    path = pinned_survey(tmp_path) if pinned else SURVEY
    out = check_out(["--mission", str(path)], capsys)
    rows = stretch_rows(out)
    assert len(rows) >= 6, out
    for start, end, _, listed in rows:
        assert listed == pytest.approx(end - start, abs=0.25), out  # rounding of 0.1 m each


def test_a_leg_pinned_to_roll_across_the_pond_is_warned_of(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = check_out(["--mission", str(pinned_survey(tmp_path))], capsys)
    warnings = [ln for ln in out.splitlines() if "is pinned to roll" in ln]
    assert len(warnings) == 1, out
    assert warnings[0].startswith("warning : stretch 1 is pinned to roll")
    assert "water 24.9 m" in warnings[0] and "mud 6.5 m" in warnings[0], warnings[0]
    out = check_out(["--mission", str(SURVEY)], capsys)
    assert "is pinned to" not in out


def test_no_warning_of_sand_on_a_map_without_sand(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = check_out(["--mission", str(SURVEY)], capsys)
    assert "sand" not in out, out
    sandy = crossing(tmp_path)
    text = (tmp_path / "water.geojson").read_text(encoding="utf-8").replace("water", "sand")
    (tmp_path / "water.geojson").write_text(text, encoding="utf-8")
    # sand is rolled by default (the sourced ground table): a crew that scrolls it is warned
    scroll_sand = tmp_path / "scroll-sand.yaml"
    scroll_sand.write_text("media:\n  modes:\n    sand: scroll\n", encoding="utf-8")
    out = check_out(["--mission", str(sandy)], capsys)
    assert "sand" in out and "warning : the map has sand" not in out, out
    args = ["check", "--mission", str(sandy), "--config", str(scroll_sand)]
    code, out, err = run_main(args, capsys)
    assert code == 0, out + err
    assert "warning : the map has sand under 40.0 m of scroll stretches" in out, out


def test_the_media_line_shows_the_map_relative_to_where_the_crew_stands(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(SURVEY.parent)
    out = check_out(["--mission", SURVEY.name], capsys)
    assert "media   : ../maps/pond-media.geojson  OK" in out, out
    monkeypatch.chdir(REPO_ROOT)
    out = check_out(["--mission", str(SURVEY)], capsys)
    assert "media   : config/maps/pond-media.geojson  OK" in out, out
