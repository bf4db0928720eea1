"""Mission entries with commands in the YAML format: named parameters with units, checked once
at the edge, written back by name and loaded back equal."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest
import yaml
from pydantic import ValidationError

from helixd.files.models import ConfigFileError
from helixd.mission.formats import mission_to_yaml
from helixd.mission.model import _NOT_PARAMS, ENTRY_KEYS, Mission, entry_yaml, load_mission


def mission(*entries: Any, frame: str = "start") -> Mission:
    return Mission.model_validate(
        {"name": "m", "mode": "roll", "frame": frame, "waypoints": list(entries)}
    )


def test_named_parameters_become_mavlink_params() -> None:
    m = mission(
        {"x": 5, "y": 0, "hold_s": 3},
        {"command": "DO_SET_SERVO", "channel": 9, "pwm_us": 1900},
        {"command": "mav_cmd_do_change_speed", "speed_mps": 0.3},
        {"command": 177, "item": 1, "repeat": 2},
    )
    hold, servo, speed, jump = m.waypoints
    assert hold.command == 16 and hold.param(0) == 3.0 and math.isnan(hold.param(3))
    assert (servo.command, servo.param(0), servo.param(1)) == (183, 9.0, 1900.0)
    assert (speed.command, speed.param(1)) == (178, 0.3)
    assert jump.name == "DO_JUMP" and jump.param(0) == 1.0 and jump.param(1) == 2.0
    assert m.points() == [(5.0, 0.0)] and m.has_commands()


@pytest.mark.parametrize(
    ("entry", "words"),
    [
        (
            {"command": "DO_SET_SERVO", "chanel": 9},
            "chanel: unknown key (did you mean channel? an entry takes x, y, north, east",
        ),
        ({"command": "DO_SET_SERVO", "channel": 0, "pwm_us": 1500}, "outside 1 .. 32"),
        ({"command": "DO_SET_SERVO", "channel": True}, "expected a number"),
        ({"command": "DO_JUMP", "item": 1.5}, "must be a whole number"),
        ({"command": "DO_SET_SERVO", "channel": 9, "params": [9, 1]}, "by name or as params"),
        ({"command": "NAV_HOVER"}, "is not a MAVLink command name"),
        ({"command": "DO_SET_SERVO", "x": 1, "y": 2}, "DO_SET_SERVO has no place"),
        ({"command": "DO_SET_SERVO", "heading_deg": 9}, "heading_deg/tolerance_m: only"),
        ({"command": "NAV_WAYPOINT", "x": 1, "y": 1, "params": [0, 0, 0, 0, 0]}, "4 param"),
        ({"command": "DO_DIGICAM_CONFIGURE", "shutter": 1}, "has no named parameters"),
    ],
)
def test_a_bad_entry_is_one_clear_error(entry: dict[str, Any], words: str) -> None:
    with pytest.raises(ValidationError) as err:
        mission({"x": 1, "y": 0}, entry)
    assert words in str(err.value), str(err.value)


def test_a_waypoints_unknown_key_hint_names_the_place_keys_too() -> None:
    """Before: a misspelt key on a plain waypoint listed only NAV_WAYPOINT's optional
    parameters (hold_s, …), never x/y/north/east/heading_deg/tolerance_m."""
    with pytest.raises(ValidationError) as err:
        mission({"x": 1, "y": 0, "tolerence_m": 1.0})
    text = str(err.value)
    assert (
        "tolerence_m: unknown key (did you mean tolerance_m? an entry takes x, y, north, " in text
    )
    for key in ("lat", "lon", "heading_deg", "via", "hold_s", "accept_radius_m"):
        assert key in text
    assert frozenset(ENTRY_KEYS) == _NOT_PARAMS  # the hint lists every key an entry takes


def test_navigation_without_coordinates_stays_where_it_is() -> None:
    m = mission({"x": 1, "y": 0}, {"command": "NAV_WAYPOINT", "hold_s": 10}, {"x": 1, "y": 0})
    assert m.points() == [(1.0, 0.0), (1.0, 0.0)]  # a hold between: the repeat is fine
    with pytest.raises(ValidationError, match=r"same point as waypoint 1 "):
        mission({"x": 1, "y": 0}, {"x": 1, "y": 0})
    with pytest.raises(ValidationError, match="no entry has a place to go"):
        mission({"command": "NAV_RETURN_TO_LAUNCH"})


def test_yaml_writes_names_and_only_what_differs(tmp_path: Path) -> None:
    m = mission(
        {"x": 5, "y": 0},
        {"command": "DO_CHANGE_SPEED", "speed_type": 1, "speed_mps": 0.3, "throttle_pct": -1},
        {"command": "NAV_WAYPOINT", "hold_s": 4},
        {"command": "DO_DIGICAM_CONFIGURE", "params": [1, 2, 3, 4, 5, 6]},
        {"command": "NAV_RETURN_TO_LAUNCH", "frame": 2, "autocontinue": False},
        {"x": 0, "y": 5, "z": 30},
    )
    rows = [entry_yaml(w) for w in m.waypoints]
    assert rows[0] == {"x": 5.0, "y": 0.0}
    assert rows[1] == {"command": "DO_CHANGE_SPEED", "speed_type": 1.0, "speed_mps": 0.3,
                       "throttle_pct": -1.0}  # fmt: skip
    assert rows[2] == {"command": "NAV_WAYPOINT", "hold_s": 4.0}
    assert rows[3]["params"] == [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
    assert rows[4] == {"command": "NAV_RETURN_TO_LAUNCH", "frame": 2, "autocontinue": False}
    assert rows[5] == {"x": 0.0, "y": 5.0, "z": 30.0}
    path = tmp_path / "m.yaml"
    path.write_text(mission_to_yaml(m))
    assert load_mission(path) == m
    assert yaml.safe_load(path.read_text())["waypoints"][2] == rows[2]


def test_the_readme_example_loads(tmp_path: Path) -> None:
    text = (Path(__file__).parents[2] / "README.md").read_text()
    start = text.index("name: sampler")
    doc = text[start : text.index("```", start)]
    path = tmp_path / "sampler.yaml"
    path.write_text(doc)
    m = load_mission(path)
    assert m.has_commands() and len(m.points()) >= 3


def test_a_file_error_names_the_entry(tmp_path: Path) -> None:
    path = tmp_path / "m.yaml"
    path.write_text(
        "name: m\nmode: roll\nwaypoints:\n  - {x: 1, y: 0}\n"
        "  - {command: DO_SET_SERVO, channel: 99, pwm_us: 1500}\n"
    )
    with pytest.raises(ConfigFileError) as err:
        load_mission(path)
    (line,) = err.value.problems
    assert (
        line.startswith(f"{path}: waypoint 2 (waypoints[1])")
        and "channel: 99 is outside 1 .. 32" in line
    )
