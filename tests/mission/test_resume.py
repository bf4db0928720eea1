"""Resume (pure core and run-directory reader): first waypoint not reached, trimmed mission
with its leg start, hash refusals, hostile run directories."""

from __future__ import annotations

import contextlib
import json
import tempfile
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from helixd.base.run_files import INPUTS_FILE
from helixd.config.load import config_to_yaml
from helixd.config.root import HelixdConfig
from helixd.mission.expand import ExpandOptions
from helixd.mission.formats import mission_to_yaml
from helixd.mission.model import Mission
from helixd.mission.resolve import resolve_plan
from helixd.mission.resume import (
    ResumeRefused,
    WalkStart,
    check_inputs,
    continued_inputs,
    first_not_reached,
    fresh_inputs,
    last_step_started,
    parse_inputs,
    resume_point,
    resumed_inputs,
    sha256_text,
    walked_options,
    with_leg_start,
    with_walk,
)
from helixd.recorder.resume_dir import read_run_dir

CFG = HelixdConfig()
CONFIG_SHA = sha256_text(config_to_yaml(CFG))


def _mission(frame: str = "local_ned", n: int = 5) -> Mission:
    if frame == "start":
        wps = [{"x": 2.0 * i + 2.0, "y": 0.0} for i in range(n)]
    else:
        wps = [{"north": 0.0, "east": 4.0 * i + 4.0} for i in range(n)]
    return Mission.model_validate(
        {"name": "line", "mode": "roll", "frame": frame, "waypoints": wps}
    )


def _reached(*indices: Any) -> list[dict[str, Any]]:
    return [{"event": "waypoint_reached", "index": i} for i in indices]


# -- first waypoint not reached ---------------------------------------------------------------


def test_nothing_reached_is_zero() -> None:
    assert first_not_reached([{"event": "run_started"}], 5) == 0


def test_in_order() -> None:
    assert first_not_reached(_reached(0, 1, 2), 5) == 3


def test_out_of_order_and_duplicates() -> None:
    assert first_not_reached(_reached(2, 0, 1, 1, 2, 0), 5) == 3


def test_torn_and_garbled_fields_are_ignored() -> None:
    events: list[dict[str, Any]] = [
        *_reached(0, 1),
        {"event": "waypoint_reached"},  # torn: no index
        {"event": "waypoint_reached", "index": "3"},
        {"event": "waypoint_reached", "index": True},
        {"event": "waypoint_reached", "index": 2.0},
        {"event": "progress", "index": 4},
    ]
    assert first_not_reached(events, 5) == 2


def test_index_outside_the_mission_is_refused() -> None:
    with pytest.raises(ResumeRefused, match="index 7"):
        first_not_reached(_reached(0, 7), 5)
    with pytest.raises(ResumeRefused):
        first_not_reached(_reached(-1), 5)


@given(st.lists(st.one_of(st.integers(0, 9), st.text(), st.none(), st.floats()), max_size=40))
def test_first_not_reached_fuzz(indices: list[Any]) -> None:
    got = first_not_reached(_reached(*indices), 10)
    ints = [i for i in indices if isinstance(i, int) and not isinstance(i, bool)]
    assert got == (max(ints) + 1 if ints else 0)


# -- inputs.json and hashes -------------------------------------------------------------------


def _inputs_for(msn: Mission) -> tuple[str, Any]:
    text = mission_to_yaml(msn)
    return text, fresh_inputs(text, CONFIG_SHA, msn)


def test_inputs_round_trip() -> None:
    text, inputs = _inputs_for(_mission())
    assert parse_inputs(inputs.to_json()) == inputs
    assert inputs.mission_sha256 == inputs.root_mission_sha256 == sha256_text(text)
    check_inputs(inputs, text, CONFIG_SHA, sha256_text(text))


def test_a_walk_from_a_later_item_is_recorded_and_read_back() -> None:
    """A flight of a mission with commands that walked from item 4 with a jump taken, at
    0.4 m/s backwards: inputs.json keeps it (a continue after a service restart reads it)."""
    _, inputs = _inputs_for(_mission())
    base = ExpandOptions(operator_continue=True, skip_unsupported=True)
    flown = ExpandOptions(
        operator_continue=True, first_item=4, jumps_taken=((6, 1),), speed_mps=0.4, reverse=True
    )
    recorded = with_walk(inputs, flown)
    assert recorded.walk == WalkStart(
        first_item=4, jumps_taken=((6, 1),), speed_mps=0.4, reverse=True
    )
    back = parse_inputs(recorded.to_json())
    assert back == recorded
    got = walked_options(base, back.walk)
    assert got == ExpandOptions(
        operator_continue=True,
        skip_unsupported=True,  # the operator's choices stay the base's
        first_item=4,
        jumps_taken=((6, 1),),
        speed_mps=0.4,
        reverse=True,
    )
    # a walk from item 1 with nothing carried records nothing: inputs.json as before
    plain = with_walk(inputs, base)
    assert plain.walk is None and "walk" not in plain.to_json()
    assert walked_options(got, None) == base


def test_a_continue_records_the_run_it_continues() -> None:
    _, inputs = _inputs_for(_mission())
    recorded = with_walk(inputs, ExpandOptions(first_item=3))
    new = continued_inputs("/runs/a", recorded, 5)
    assert new.walk is None  # the new flight records its own walk when it starts
    assert new.mission_sha256 == inputs.mission_sha256
    assert new.resumed_from is not None and new.resumed_from.path == "/runs/a"
    assert new.resumed_from.first_waypoint == 4


def test_the_last_step_started_is_read_from_the_events() -> None:
    def started(step: Any, kind: str = "step_started") -> dict[str, Any]:
        return {"event": "mission_step", "kind": kind, "step": step, "item": 3}

    assert last_step_started([{"event": "run_started"}]) == 0
    events = [started(1), started(1, "step_completed"), started(2), started(3, "hold_started")]
    assert last_step_started(events) == 2
    garbled = [started(4), started("5"), started(True), started(None), "junk"]
    assert last_step_started(garbled) == 4  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "garbage", ["", "{", "[]", '{"format": 1}', "\x00\x01", '{"format": 2, "x": 1}']
)
def test_corrupt_inputs_are_refused(garbage: str) -> None:
    with pytest.raises(ResumeRefused, match=r"inputs\.json"):
        parse_inputs(garbage)


@given(st.text(max_size=200))
def test_parse_inputs_fuzz(text: str) -> None:
    with contextlib.suppress(ResumeRefused):  # refused with a message, or parsed
        parse_inputs(text)


def test_mission_changed_is_refused() -> None:
    text, inputs = _inputs_for(_mission())
    with pytest.raises(ResumeRefused, match=r"mission\.yaml .*changed"):
        check_inputs(inputs, text.replace("4.0", "4.5"), CONFIG_SHA)


def test_config_changed_is_refused() -> None:
    text, inputs = _inputs_for(_mission())
    other = CFG.model_copy(
        update={"control": CFG.control.model_copy(update={"max_speed_mps": 0.3})}
    )
    with pytest.raises(ResumeRefused, match="config changed"):
        check_inputs(inputs, text, sha256_text(config_to_yaml(other)))


def test_explicit_other_mission_is_refused() -> None:
    text, inputs = _inputs_for(_mission())
    with pytest.raises(ResumeRefused, match="--mission differs"):
        check_inputs(inputs, text, CONFIG_SHA, sha256_text(text + "\n# edited"))


# -- the trimmed mission and its leg start ----------------------------------------------------


def test_trimmed_mission_starts_at_first_not_reached_with_leg_start() -> None:
    msn = _mission()
    _, inputs = _inputs_for(msn)
    point = resume_point("/runs/a", inputs, msn, _reached(0, 1), completed=False)
    assert point.first_index == 2
    assert [w.east for w in point.mission.waypoints] == [12.0, 16.0, 20.0]
    assert point.inputs.leg_start == msn.waypoints[1]
    assert point.inputs.index_offset == 2
    assert point.inputs.waypoints_total == 5
    assert point.inputs.resumed_from is not None
    assert point.inputs.resumed_from.path == "/runs/a"
    assert point.inputs.resumed_from.first_waypoint == 2
    # the plan flies the remainder; its first leg starts at waypoint 1 (east 8, north 0)
    plan = resolve_plan(point.mission, CFG.control, CFG.mission)
    plan = with_leg_start(plan, point.mission, point.inputs.leg_start, CFG.control, CFG.mission)
    assert plan.leg_start_xy_m == (8.0, 0.0)  # x = east, y = north
    assert [(w.x_m, w.y_m) for w in plan.waypoints] == [(12.0, 0.0), (16.0, 0.0), (20.0, 0.0)]


def test_nothing_reached_keeps_the_rover_as_leg_start() -> None:
    msn = _mission()
    _, inputs = _inputs_for(msn)
    point = resume_point("/runs/a", inputs, msn, [], completed=False)
    assert point.inputs.leg_start is None and point.first_index == 0
    plan = resolve_plan(point.mission, CFG.control, CFG.mission)
    assert with_leg_start(plan, point.mission, None, CFG.control, CFG.mission) is plan


def test_resume_of_a_resume_counts_the_whole_mission() -> None:
    msn = _mission(n=6)
    _, inputs = _inputs_for(msn)
    first = resume_point("/runs/a", inputs, msn, _reached(0, 1), completed=False)
    yaml2 = mission_to_yaml(first.mission)
    inputs2 = resumed_inputs(first, yaml2)
    check_inputs(inputs2, yaml2, CONFIG_SHA, inputs.root_mission_sha256)
    # the second run reached nothing: the leg start is still whole-mission waypoint 1
    again = resume_point("/runs/b", inputs2, first.mission, [], completed=False)
    assert again.first_index == 2 and again.inputs.leg_start == msn.waypoints[1]
    # it reached its own index 1 (whole-mission 3): continue at whole-mission 4
    later = resume_point("/runs/b", inputs2, first.mission, _reached(0, 1), completed=False)
    assert later.first_index == 4
    assert later.inputs.leg_start == msn.waypoints[3]
    assert [w.east for w in later.mission.waypoints] == [20.0, 24.0]


def test_the_operators_numbers_continue_past_via_points() -> None:
    """Waypoints 0 and 2 of the planned mission are via points: after reaching the first
    three, the remainder starts at the operator's waypoint 2 of 3."""
    msn = _mission()
    vias = (True, False, True, False, False)
    msn = msn.model_copy(
        update={
            "waypoints": tuple(
                w.model_copy(update={"via": v}) for w, v in zip(msn.waypoints, vias, strict=True)
            )
        }
    )
    _, inputs = _inputs_for(msn)
    assert inputs.operator_total == 3
    point = resume_point("/runs/a", inputs, msn, _reached(0, 1, 2), completed=False)
    assert (point.inputs.operator_offset, point.inputs.operator_total) == (1, 3)
    numbering = point.inputs.numbering([w.via for w in point.mission.waypoints])
    assert [numbering.label(i) for i in range(2)] == ["2/3", "3/3"]


def test_completed_run_is_refused() -> None:
    msn = _mission()
    _, inputs = _inputs_for(msn)
    with pytest.raises(ResumeRefused, match="completed already"):
        resume_point("/r", inputs, msn, _reached(0, 1), completed=True)
    with pytest.raises(ResumeRefused, match="every waypoint"):
        resume_point("/r", inputs, msn, _reached(0, 1, 2, 3, 4), completed=False)


def test_start_frame_is_refused() -> None:
    msn = _mission("start")
    _, inputs = _inputs_for(msn)
    with pytest.raises(ResumeRefused, match="start-frame"):
        resume_point("/r", inputs, msn, _reached(0), completed=False)


def test_inconsistent_count_is_refused() -> None:
    msn = _mission()
    _, inputs = _inputs_for(_mission(n=6))
    with pytest.raises(ResumeRefused, match="inconsistent"):
        resume_point("/r", inputs, msn, [], completed=False)


# -- hostile run directories ------------------------------------------------------------------


def _run_dir(tmp_path: Path, events: str, summary: str | None = None) -> Path:
    msn = _mission()
    text, inputs = _inputs_for(msn)
    d = tmp_path / "run"
    d.mkdir()
    (d / "mission.yaml").write_text(text)
    (d / INPUTS_FILE).write_text(inputs.to_json())
    (d / "events.jsonl").write_text(events)
    if summary is not None:
        (d / "summary.json").write_text(summary)
    return d


STARTED = json.dumps({"event": "run_started", "t_mono_s": 1.0}) + "\n"


def test_truncated_events_are_read(tmp_path: Path) -> None:
    lines = [json.dumps({"event": "waypoint_reached", "index": i}) for i in (0, 1)]
    torn = '{"event": "waypoint_reached", "ind'
    d = _run_dir(tmp_path, STARTED + "\n".join(lines) + "\n" + torn)
    got = read_run_dir(d)
    assert first_not_reached(got.events, 5) == 2 and not got.completed


@pytest.mark.parametrize(
    ("events", "summary", "match"),
    [
        ("garbage\n\x00\x00", None, "run_started"),
        ("", None, "run_started"),
        (STARTED, "{not json", "corrupt"),
        (STARTED, '{"completed": "yes"}', "corrupt"),
        (STARTED, "[1, 2]", "corrupt"),
    ],
)
def test_corrupt_run_dirs_are_refused(
    tmp_path: Path, events: str, summary: str | None, match: str
) -> None:
    with pytest.raises(ResumeRefused, match=match):
        read_run_dir(_run_dir(tmp_path, events, summary))


def test_missing_pieces_are_refused(tmp_path: Path) -> None:
    with pytest.raises(ResumeRefused, match="not a run directory"):
        read_run_dir(tmp_path / "nope")
    d = _run_dir(tmp_path, STARTED)
    (d / "mission.yaml").unlink()
    with pytest.raises(ResumeRefused, match="missing"):
        read_run_dir(d)
    (d / INPUTS_FILE).unlink()
    with pytest.raises(ResumeRefused, match=r"no inputs\.json"):
        read_run_dir(d)


def test_completed_summary_is_read(tmp_path: Path) -> None:
    d = _run_dir(tmp_path, STARTED, json.dumps({"completed": True}))
    assert read_run_dir(d).completed


@given(st.binary(max_size=300), st.one_of(st.none(), st.binary(max_size=100)))
def test_read_run_dir_fuzz(events: bytes, summary: bytes | None) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        d = _run_dir(Path(tmp), "")
        (d / "events.jsonl").write_bytes(events)
        if summary is not None:
            (d / "summary.json").write_bytes(summary)
        try:
            got = read_run_dir(d)
        except ResumeRefused as exc:
            assert str(exc)  # a reason, one line
            assert "\n" not in str(exc)
        else:
            assert isinstance(got.completed, bool)
            with contextlib.suppress(ResumeRefused):  # an index outside the mission
                first_not_reached(got.events, 5)
