"""The flight a run makes of a checked mission: flown as it is with nothing in the way; planned
around a keep-out with the planned text recorded, the route's lines and a first leg re-planned
from the rover at preflight; a map that cannot be read refused in one line (exit 2)."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.config.root import HelixdConfig
from helixd.mission.model import Mission
from helixd.prepare.inputs import InputsRefused
from helixd.prepare.planned import load_occupancy, place_labels, planned_flight, route_lines

WALL = {"planning": {"keep_out_polygons_ne_m": [[[8, -3], [8, 3], [10, 3], [10, -3]]]}}
AHEAD = Mission.model_validate(
    {
        "name": "t",
        "mode": "roll",
        "frame": "local_ned",
        "waypoints": [{"north": 18, "east": 0, "tolerance_m": 0.8}, {"north": 18, "east": 5}],
    }
)


def test_nothing_in_the_way_is_flown_as_it_is() -> None:
    flight = planned_flight(HelixdConfig(), AHEAD, "text", Path("m.yaml"), None, "cfg-sha")
    assert flight.mission is AHEAD and flight.route is None and flight.replan_from is None
    assert flight.mission_yaml == "text"
    assert flight.inputs.config_sha256 == "cfg-sha"


def test_a_keep_out_is_planned_around_and_the_first_leg_replanned_from_the_rover() -> None:
    cfg = HelixdConfig.model_validate(WALL)
    flight = planned_flight(cfg, AHEAD, "text", Path("m.yaml"), None, "cfg-sha")
    assert flight.route is not None and len(flight.mission.waypoints) > 2
    assert flight.mission.waypoints[-2:] == AHEAD.waypoints  # the operator's places kept
    assert flight.mission_yaml != "text"  # the record is what is flown, the detour included
    assert flight.inputs.mission_sha256 != ""
    lines = route_lines(flight.route, flight.mission)
    assert lines[0].startswith("planned : clearance")
    assert "leg start → wp 1" in lines[1] and "intermediate" in lines[1]
    assert "leg wp 1 → wp 2" in "\n".join(lines) and "(straight)" in "\n".join(lines)
    assert flight.replan_from is not None
    again = flight.replan_from((0.0, 6.0), None)  # the rover is east of where it was planned
    assert again.waypoints[-2:] == AHEAD.waypoints
    assert again.waypoints[0] != flight.mission.waypoints[0]


def test_places_are_named_by_item_in_a_mission_with_commands() -> None:
    assert place_labels(AHEAD) == ["wp 1", "wp 2"]
    servo = {"command": "DO_SET_SERVO", "channel": 9, "pwm_us": 1500}
    wps = [{"north": 5, "east": 0}, servo, {"north": 5, "east": 5}]
    with_commands = AHEAD.model_validate(
        {"name": "c", "mode": "roll", "frame": "local_ned", "waypoints": wps}
    )
    assert place_labels(with_commands) == ["item 1", "item 3"]


def test_no_map_no_occupancy_and_a_bad_map_is_one_line(tmp_path: Path) -> None:
    assert load_occupancy(HelixdConfig(), None) is None
    bad = tmp_path / "map.yaml"
    bad.write_text("image: nowhere.pgm\n", encoding="utf-8")
    with pytest.raises(InputsRefused) as refused:
        load_occupancy(HelixdConfig(), bad)
    assert refused.value.code is ExitCode.USAGE and len(refused.value.problems) == 1
