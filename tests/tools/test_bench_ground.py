"""The ground bench's pure parts: its own truths differ from the built-in table, the fastest
mode per medium, the learning error read from a profile, the verdicts, the results section."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.base.media import Medium
from helixd.base.plan import MotionMode
from helixd.config.root import HelixdConfig
from helixd.control.ground_fit import AxisSums, CellSums
from helixd.plant.ground import TerrainTable, read_ground_file
from helixd.recorder.ground_profile import GroundProfile, write_profile
from tests.support.tools import load_tool

bench = load_tool("bench_ground")
res = load_tool("bench_results")


def test_the_benchs_own_truths_differ_from_the_table_and_read_as_ground_files(
    tmp_path: Path,
) -> None:
    files = bench.truth_files([], tmp_path)
    assert len(files) >= 2
    for path in files:
        truth = read_ground_file(path)
        assert truth != TerrainTable()
    given = tmp_path / "mine.yaml"
    assert bench.truth_files([given], tmp_path) == [given]


def test_fastest_and_the_media_the_survey_crosses(tmp_path: Path) -> None:
    best = bench.fastest(TerrainTable(), HelixdConfig())
    assert best[Medium.HARD] is MotionMode.ROLL and best[Medium.WATER] is MotionMode.SCROLL
    rolling_mud = TerrainTable.model_validate({"mud": {"roll_efficiency": 0.9}})
    assert bench.fastest(rolling_mud, HelixdConfig())[Medium.MUD] is MotionMode.ROLL
    crossed = bench.crossed_media(bench.survey_mission(tmp_path))
    assert set(crossed) == {Medium.HARD, Medium.MUD, Medium.WATER}


def test_learned_error_counts_cells_flown_20_m_on_their_driven_axis(tmp_path: Path) -> None:
    profile = tmp_path / "p.yaml"
    far = CellSums(scroll=AxisSums(1.0, 0.55, 0.31, 30.0, 1500), metres=40.0)  # truth 0.62
    near = CellSums(roll=AxisSums(1.0, 0.1, 0.01, 5.0, 250), metres=3.0)  # under 20 m
    write_profile(
        profile,
        GroundProfile(
            {(Medium.WATER, MotionMode.SCROLL): far, (Medium.MUD, MotionMode.ROLL): near}
        ),
    )
    err = bench.learned_max_rel_error(profile, TerrainTable())
    assert err == pytest.approx(abs(0.55 - 0.62) / 0.62)


def test_verdicts_and_the_results_section() -> None:
    runs = [
        {"completed": True, "time_s": 600.0, "estimate_s": 500.0, "energy_j": 1.0},
        {"completed": True, "time_s": 600.0, "estimate_s": 610.0, "energy_j": 1.0},
        {"completed": True, "time_s": 600.0, "estimate_s": 640.0, "energy_j": 1.0},
    ]
    section = {
        "site": {
            "runs": runs,
            "learned_max_rel_error": 0.02,
            "policy": {
                "hard": {"picked": "roll", "fastest": "roll"},
                "mud": {"picked": "scroll", "fastest": "roll"},
            },
        }
    }
    lines = bench.verdicts(section)
    assert "site: learned_max_rel_error 0.020 (goal <= 0.1: met)" in lines
    assert any(
        "run 3 estimate 640 s" in ln and "MISSED" in ln and "run 1 -16.7%" in ln for ln in lines
    )
    assert "site: policy picked the fastest mode in 1/2 media crossed (MISSED: mud)" in lines
    merged = res.merge_section({}, "ground", section)
    assert "## Ground" in res.render_markdown(merged)
