"""The simulator's ground table (its sourced defaults) and the ground file that replaces any
part of it (``--sim-ground``): every field defaulted, hostile input refused naming the file,
the medium's field and the range."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.files.models import ConfigFileError
from helixd.plant.ground import DEFAULT_TRACTION, TerrainTable, read_ground_file

TABLE = TerrainTable()


def test_scroll_fractions_follow_the_screw_vehicles_speed_ratios() -> None:
    """docs/physics.md: firm soil against mud/marsh 1.6/12.5 mph (Marsh Screw) and 3.6/25 kn
    (RUC); water against marsh or mud 15.7/25 kn (RUC) and 10/12 km/h (Amphirol)."""
    mud = TABLE.mud.scroll_efficiency
    assert 1.6 / 12.5 - 0.01 <= TABLE.hard.scroll_efficiency / mud <= 3.6 / 25.0 + 0.01
    assert 15.7 / 25.0 <= TABLE.water.scroll_efficiency / mud <= 10.0 / 12.0
    assert TABLE.sand.scroll_efficiency <= TABLE.hard.scroll_efficiency  # "especially sand"
    # energy follows slip: one power per rpm, so a scroll that slips pays more per metre
    assert {getattr(TABLE, m).power_w for m in DEFAULT_TRACTION} == {100.0}


def test_rolling_beats_scrolling_on_firm_ground_and_scrolling_wins_afloat() -> None:
    for firm in (TABLE.hard, TABLE.grass):
        assert firm.roll_efficiency > 3 * firm.scroll_efficiency
    for soft in (TABLE.mud, TABLE.water):
        assert soft.scroll_efficiency > 2 * soft.roll_efficiency


def test_a_ground_file_replaces_only_what_it_names(tmp_path: Path) -> None:
    path = tmp_path / "site.yaml"
    path.write_text("mud:\n  scroll_efficiency: 0.7\n  power_w: 140\nwater: {}\n")
    got = read_ground_file(path)
    assert got.mud.scroll_efficiency == 0.7 and got.mud.power_w == 140.0
    assert got.mud.roll_efficiency == TABLE.mud.roll_efficiency  # the rest: the defaults
    assert got.water == TABLE.water and got.hard == TABLE.hard
    empty = tmp_path / "empty.yaml"
    empty.write_text("")
    assert read_ground_file(empty) == TABLE


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("lava: {roll_efficiency: 0.5}\n", "lava: unknown key (allowed keys here: grass, hard"),
        ("mud: {grip: 1}\n", "mud.grip: unknown key (got 1; allowed keys here: dig_rate_per_m"),
        ("sand: {yaw_efficiency: 1.5}\n", "sand.yaw_efficiency: Input should be less than or "),
        ("hard: {roll_efficiency: .nan}\n", "hard.roll_efficiency: Input should be a finite"),
        ("hard: {power_w: .inf}\n", "hard.power_w: Input should be a finite number"),
        ("hard: {dig_rate_per_m: -1}\n", "hard.dig_rate_per_m: Input should be greater than or"),
        ("hard: {scroll_efficiency: yes}\n", "hard.scroll_efficiency: "),
        ("hard: {scroll_efficiency: true}\n", "hard: scroll_efficiency: true/false is not a"),
        ("hard: 0.5\n", "hard: Input should be a valid dictionary or instance of TerrainTraction"),
        ("- hard\n", "(top level): expected a mapping of keys, got list"),
        ("hard: {roll_efficiency: 0.5}\nhard: {}\n", "duplicate key"),
    ],
)
def test_a_hostile_ground_file_is_refused_naming_file_field_and_range(
    tmp_path: Path, text: str, expected: str
) -> None:
    path = tmp_path / "ground.yaml"
    path.write_text(text)
    with pytest.raises(ConfigFileError) as err:
        read_ground_file(path)
    lines = err.value.problems
    assert any(expected in line for line in lines), lines
    assert all(line.startswith(str(path)) for line in lines), lines
    if "less than" in expected or "greater than" in expected:
        assert any("allowed range 0.0 .. " in line for line in lines), lines
