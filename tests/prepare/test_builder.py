"""The one builder for a flight: a file and the autopilot's copy of the same mission are
refused for the same reason, before anything connects (the autopilot's home stands for the
EKF origin as a file's home row does)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.base.plan import MotionMode
from helixd.config.root import HelixdConfig
from helixd.mission.expand import ExpandOptions
from helixd.mission.formats import mission_to_yaml, read_gcs
from helixd.mission.formats.wire import gcs_to_wire
from helixd.mission.resolve import resolve
from helixd.mission.resume import fresh_inputs, with_walk
from helixd.prepare.autopilot_mission import convert_download
from helixd.prepare.builder import (
    AutopilotMission,
    AutopilotPlace,
    AutoWalk,
    MissionFile,
    continue_commands,
    from_autopilot_item,
    prepare_flight,
)
from helixd.prepare.inputs import InputsRefused
from helixd.prepare.planned import Flight
from tests.support.missions import mission_of, points_mission
from tests.support.paths import DATA_DIR, REPO_ROOT

CFG = HelixdConfig()
HOME = (53.523250, -113.526110)
DEG_PER_M = 1 / 111_320.0


def _waypoints(tmp_path: Path, first_north_m: float) -> Path:
    rows = [
        "QGC WPL 110",
        f"0\t1\t0\t16\t0\t0\t0\t0\t{HOME[0]:.8f}\t{HOME[1]:.8f}\t668.0\t1",
        *(
            f"{i}\t0\t3\t16\t0\t0\t0\t0\t{HOME[0] + n * DEG_PER_M:.8f}\t{HOME[1]:.8f}\t0.0\t1"
            for i, n in enumerate((first_north_m, first_north_m + 20.0), start=1)
        ),
    ]
    path = tmp_path / "mission.waypoints"
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def test_a_file_and_its_upload_are_refused_alike(tmp_path: Path) -> None:
    path = _waypoints(tmp_path, 794.0)
    with pytest.raises(InputsRefused) as from_file:
        prepare_flight(MissionFile(path, MotionMode.ROLL), None)
    assert from_file.value.code is ExitCode.USAGE
    wire = gcs_to_wire(read_gcs(path))
    cfg = HelixdConfig()
    source = "autopilot at test"
    got = convert_download(wire.mission, (), source=source, cfg=cfg, mode=MotionMode.ROLL)
    assert got.mission.home == pytest.approx(HOME)
    with pytest.raises(InputsRefused) as from_autopilot:
        prepare_flight(AutopilotMission(got, cfg), None)
    assert from_autopilot.value.code is ExitCode.PREFLIGHT  # as `run --mission autopilot`
    reasons = [p.split(": ", 1)[1] for p in from_file.value.problems]
    assert reasons == [p.split(": ", 1)[1] for p in from_autopilot.value.problems]
    assert any("794.0 m from the mission's home" in r for r in reasons), reasons


def test_a_file_near_its_home_is_a_flight(tmp_path: Path) -> None:
    got = prepare_flight(MissionFile(_waypoints(tmp_path, 30.0), MotionMode.ROLL), None)
    assert got.flight.mission is got.mission  # nothing to plan around
    assert got.flight.inputs.mission_sha256
    assert got.cfg.safety.mission_time_limit_s > 0


def test_the_shipped_ground_station_files_are_flights() -> None:
    for name in ("square.waypoints", "sim_square.plan"):
        got = prepare_flight(MissionFile(DATA_DIR / name, MotionMode.ROLL), None)
        assert got.path == DATA_DIR / name


def three_waypoints() -> Flight:
    msn = points_mission("local_ned", [(0, 10), (8, 10), (8, 0)], "roll", name="m")
    text = mission_to_yaml(msn)
    return Flight(msn, text, None, fresh_inputs(text, "c" * 64, msn))


def test_a_flight_from_the_autopilots_current_item() -> None:
    flight = three_waypoints()
    assert from_autopilot_item(flight, 0, CFG) is flight  # no current item: from the start
    assert from_autopilot_item(flight, 1, CFG) is flight
    later = from_autopilot_item(flight, 3, CFG)
    assert [(w.north, w.east) for w in later.mission.waypoints] == [(8, 0)]
    # the first leg re-enters the one from waypoint 2; numbered as the whole mission
    start = later.inputs.leg_start
    assert start is not None and (start.north, start.east) == (8, 10)
    assert later.inputs.numbering([False]).label(0) == "3/3"
    # the crew set the item mid-leg: the first leg starts where the rover is (no leg start)
    here = from_autopilot_item(flight, 3, CFG, from_here=True)
    assert here.mission == later.mission and here.inputs.leg_start is None
    assert here.inputs.numbering([False]).label(0) == "3/3"
    with pytest.raises(InputsRefused, match="past the mission's last waypoint"):
        from_autopilot_item(flight, 4, CFG)


def commands_flight(*extra: dict[str, object]) -> Flight:
    speed = {"command": "DO_CHANGE_SPEED", "speed_mps": 0.3}
    jump = {"command": "DO_JUMP", "item": 1, "repeat": 1}
    wps = [{"north": 0, "east": 10}, speed, {"north": 8, "east": 10}, {"north": 8, "east": 0}]
    msn = mission_of("local_ned", [*wps, jump, *extra], name="m")
    text = mission_to_yaml(msn)
    return Flight(msn, text, None, fresh_inputs(text, "c" * 64, msn))


def test_a_mission_with_commands_from_the_autopilots_current_item() -> None:
    """The whole mission, walked from the current item as ArduPilot runs it: the DO before it
    not run, the DO_JUMP after it still jumping back to item 1."""
    flight = commands_flight()
    assert from_autopilot_item(flight, 1, CFG) is flight
    later = from_autopilot_item(flight, 3, CFG)
    assert later.mission is flight.mission and later.inputs == flight.inputs
    assert later.options == ExpandOptions(first_item=3)
    plan = resolve(later.mission, CFG.control, CFG.mission, options=later.options).plan
    assert plan.program is not None
    assert [s.item for s in plan.program.steps] == [3, 4, 1, 3, 4]
    assert [s.speed_mps for s in plan.program.steps] == [0.6, 0.6, 0.6, 0.3, 0.3]


def test_the_jump_counters_of_a_flight_let_go_on_a_later_lap_carry_on() -> None:
    """Let go on lap 2 (step 4, item 1 after the DO_JUMP): the autopilot keeps its counters
    (AP_Mission::resume), so AUTO again flies the rest of lap 2 only, from item 3 or item 1."""
    flight = commands_flight()  # flown 1, 3, 4, 1, 3, 4
    first_lap = AutoWalk(ExpandOptions(), 1)
    assert from_autopilot_item(flight, 1, CFG, first_lap) is flight
    lap2 = AutoWalk(ExpandOptions(), 4)
    for seq, expected in ((3, [3, 4]), (1, [1, 3, 4])):
        later = from_autopilot_item(flight, seq, CFG, lap2)
        assert later.options == ExpandOptions(first_item=seq, jumps_taken=((5, 1),))
        plan = resolve(later.mission, CFG.control, CFG.mission, options=later.options).plan
        assert plan.program is not None
        assert [s.item for s in plan.program.steps] == expected


def test_a_set_current_item_keeps_the_counters_the_autopilot_held_where_it_was() -> None:
    """The crew sets item 1 while the autopilot is on lap 2 (step 5, item 3 after the
    DO_JUMP): set_current_cmd keeps the counters (the jump taken once of once), so the next
    flight is one lap, 1 3 4, not two. The replay of a let-go flight would not find item 1
    ahead of step 5 and count from zero."""
    flight = commands_flight()  # flown 1, 3, 4, 1, 3, 4
    set_on_lap2 = AutoWalk(ExpandOptions(), 5, exact=True)
    later = from_autopilot_item(flight, 1, CFG, set_on_lap2)
    assert later.options == ExpandOptions(first_item=1, jumps_taken=((5, 1),))
    plan = resolve(later.mission, CFG.control, CFG.mission, options=later.options).plan
    assert plan.program is not None
    assert [s.item for s in plan.program.steps] == [1, 3, 4]
    replayed = from_autopilot_item(flight, 1, CFG, AutoWalk(ExpandOptions(), 5))
    assert replayed is flight  # the let-go rule: item 1 not current again after step 5
    set_on_lap1 = AutoWalk(ExpandOptions(), 2, exact=True)  # item 3, nothing jumped yet
    assert from_autopilot_item(flight, 1, CFG, set_on_lap1) is flight


def test_a_start_the_walk_from_there_cannot_fly_is_refused() -> None:
    flight = commands_flight({"command": "NAV_DELAY", "delay_s": -1})  # until a time of day
    with pytest.raises(InputsRefused, match=r"cannot start at the autopilot's item 3: item 6"):
        from_autopilot_item(flight, 3, CFG)


def test_the_autopilots_place_is_a_checked_flight_of_one_leg() -> None:
    cfg = HelixdConfig()
    got = prepare_flight(AutopilotPlace(52.0, 13.0, "RTL", cfg, MotionMode.ROLL), None)
    (wp,) = got.flight.mission.waypoints
    assert (wp.lat, wp.lon) == (52.0, 13.0) and got.flight.mission.name == "RTL"
    with pytest.raises(InputsRefused):  # checked as a mission: off the Earth is refused
        prepare_flight(AutopilotPlace(95.0, 13.0, "GUIDED", cfg, MotionMode.ROLL), None)


def interrupted(
    tmp_path: Path, flight: Flight, steps: int, walk: ExpandOptions, completed: bool = False
) -> Path:
    """A run directory of ``flight`` walked with ``walk``, stopped after starting ``steps``."""
    run = tmp_path / "run"
    run.mkdir()
    (run / "mission.yaml").write_text(flight.mission_yaml, encoding="utf-8")
    (run / "inputs.json").write_text(with_walk(flight.inputs, walk).to_json(), encoding="utf-8")
    events = [{"event": "run_started"}]
    for n in range(1, steps + 1):
        if n > 1:
            done = n - 1
            events.append({"event": "mission_step", "kind": "step_completed", "step": done})
        events.append({"event": "mission_step", "kind": "step_started", "step": n, "item": 0})
    (run / "events.jsonl").write_text("".join(json.dumps(e) + "\n" for e in events))
    if completed:
        (run / "summary.json").write_text(json.dumps({"completed": True}))
    return run


def items_of(flight: Flight) -> list[int]:
    plan = resolve(flight.mission, CFG.control, CFG.mission, options=flight.options).plan
    assert plan.program is not None
    return [s.item for s in plan.program.steps]


def test_a_commands_flight_continues_with_the_step_it_stopped_at(tmp_path: Path) -> None:
    """Stopped on lap 2 (step 4, item 1 after the DO_JUMP; walk 1 3 4 1 3 4): the continue
    flies 1 3 4, the jump counted once, at item 2's 0.3 m/s set on lap 1."""
    flight = commands_flight()
    run = interrupted(tmp_path, flight, 4, ExpandOptions())
    again = continue_commands(flight, run, CFG)
    assert again.mission is flight.mission
    assert again.options == ExpandOptions(first_item=1, jumps_taken=((5, 1),), speed_mps=0.3)
    assert items_of(again) == [1, 3, 4]
    assert again.inputs.resumed_from is not None
    assert again.inputs.resumed_from.path == str(run.resolve())


def test_a_flight_that_itself_started_later_continues_its_own_walk(tmp_path: Path) -> None:
    """A flight from item 3 (its inputs.json keeps it, so a restarted service knows), stopped
    on its step 4 (item 3 of lap 2): item 2's DO_CHANGE_SPEED, started with that step, starts
    again with it; no speed carried (item 2 had not run before that step)."""
    flight = commands_flight()
    run = interrupted(tmp_path, flight, 4, ExpandOptions(first_item=3))  # walk 3 4 1 3 4
    again = continue_commands(flight, run, CFG)
    assert again.options == ExpandOptions(first_item=2, jumps_taken=((5, 1),))
    assert items_of(again) == [3, 4]
    # stopped before its first step started: its own walk again
    (tmp_path / "run").rename(tmp_path / "old")
    run = interrupted(tmp_path, flight, 0, ExpandOptions(first_item=3))
    assert continue_commands(flight, run, CFG).options == ExpandOptions(first_item=3)


def test_a_flight_the_autopilot_drove_continues_from_the_autopilots_own_step(
    tmp_path: Path,
) -> None:
    """A flight of the autopilot's AUTO interrupted while helixd still flew step 1 (item 1)
    and the autopilot's current item was on step 2 (item 3: the crew's set current to the next
    item, or its own arrival ahead): the continue goes on from the autopilot's step, as AUTO
    again would (soak seed 23: the continue flew item 1 again after a kill)."""
    flight = commands_flight()
    run = interrupted(tmp_path, flight, 1, ExpandOptions())  # walk 1 3 4 1 3 4
    with (run / "events.jsonl").open("a", encoding="utf-8") as fh:
        fh.write(json.dumps({"event": "autopilot_step", "item": 3, "step": 2}) + "\n")
    again = continue_commands(flight, run, CFG)
    assert items_of(again)[:2] == [3, 4], items_of(again)


def test_a_continue_of_another_mission_or_a_completed_run_is_refused(tmp_path: Path) -> None:
    flight = commands_flight()
    run = interrupted(tmp_path, flight, 2, ExpandOptions(), completed=True)
    with pytest.raises(InputsRefused, match="completed already"):
        continue_commands(flight, run, CFG)
    other = commands_flight({"north": 1, "east": 1})
    with pytest.raises(InputsRefused, match="another mission"):
        continue_commands(other, run, CFG)


def test_the_mode_flag_turns_the_media_plan_off_for_the_flight(tmp_path: Path) -> None:
    """``run --mode roll`` on a mission with a media map and a pinned leg: no map is read for
    the flight (no stops, no stretch in another mode), the config's map off too, said once."""
    from_repo = REPO_ROOT / "config"
    config = tmp_path / "helixd.yaml"
    config.write_text(
        f"media:\n  media_map: {from_repo / 'maps' / 'pond-media.geojson'}\n", encoding="utf-8"
    )
    text = (from_repo / "missions" / "pond-survey.yaml").read_text(encoding="utf-8")
    text = text.replace("../maps/pond-media.geojson", str(from_repo / "maps/pond-media.geojson"))
    text = text.replace("  lon: -113.5263200\n", "  lon: -113.5263200\n  mode: scroll\n", 1)
    path = tmp_path / "pond.yaml"
    path.write_text(text, encoding="utf-8")
    got = prepare_flight(MissionFile(path, MotionMode.ROLL), config)
    assert got.media is None and got.cfg.media.media_map is None
    assert got.mission.media_map is None and got.mission.mode is MotionMode.ROLL
    assert all(w.mode is None for w in got.mission.waypoints)
    notes = [n for n in got.notes if "wins over" in n]
    assert len(notes) == 1 and "waypoints' own modes (1)" in notes[0], got.notes
    assert "media map" in notes[0] and "every leg is flown in roll" in notes[0]
