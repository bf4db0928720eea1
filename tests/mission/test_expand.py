"""ArduPilot's walk through a mission (AP_Mission.cpp) and what Rover does with each item
(mode_auto.cpp), as :mod:`helixd.mission.expand` ports them: checked on small missions whose
flown order and timing are worked out by hand from the C++."""

from __future__ import annotations

import itertools
import math
from typing import Any

import pytest

from helixd.base.plan import ActionKind, Plan
from helixd.config.root import HelixdConfig
from helixd.mission.expand import PATROL_STEPS_MAX, ExpandOptions, carried_at_step
from helixd.mission.model import Mission
from helixd.mission.resolve import Resolved, Where, resolve
from helixd.mission.walk import jumps_when_current, restart_at_step, walk_at_step

CFG = HelixdConfig()


def mission(*entries: dict[str, Any], frame: str = "start", **extra: Any) -> Mission:
    return Mission.model_validate(
        {"name": "t", "mode": "roll", "frame": frame, "waypoints": list(entries), **extra}
    )


def flown(
    *entries: dict[str, Any],
    options: ExpandOptions | None = None,
    where: Where | None = None,
    extra: dict[str, Any] | None = None,
) -> Resolved:
    m = mission(*entries, **(extra or {}))
    return resolve(m, CFG.control, CFG.mission, None, where or Where(), options or ExpandOptions())


def items(r: Resolved) -> list[int]:
    """The mission items of the steps, in flight order."""
    assert r.plan.program is not None
    return [s.item for s in r.plan.program.steps]


def points(plan: Plan) -> list[tuple[float, float]]:
    return [(round(w.x_m, 3), round(w.y_m, 3)) for w in plan.waypoints]


A, B, C = {"x": 5, "y": 0}, {"x": 5, "y": 5}, {"x": 0, "y": 5}


def jump(item: int, repeat: int) -> dict[str, Any]:
    return {"command": "DO_JUMP", "item": item, "repeat": repeat}


def test_do_jump_repeat_one_flies_the_loop_twice() -> None:
    r = flown(A, B, C, jump(2, 1))  # items 1..4: the jump back to item 2 once
    assert items(r) == [1, 2, 3, 2, 3]
    assert points(r.plan) == [(5, 0), (5, 5), (0, 5), (5, 5), (0, 5)]
    assert r.problems == ()


def test_nested_jumps_reset_the_inner_counter_as_ardupilot_does() -> None:
    """get_next_cmd zeroes a finished jump's counter (MIS_OPTIONS DONT_ZERO_COUNTER off), so
    the outer loop runs the inner loop in full again: 2 × (2 × inner) passes."""
    inner, outer = jump(2, 1), jump(1, 1)  # items 3 and 5
    r = flown(A, B, inner, C, outer)
    assert items(r) == [1, 2, 2, 4, 1, 2, 2, 4]


def test_a_jump_forever_is_a_patrol_planned_beyond_the_time_limit() -> None:
    """DO_JUMP repeat -1 is accepted as Rover flies it: laps until stopped. The walk unrolls
    laps until a whole lap lies beyond the time limit in force; the last step holds, so the
    plan never 'completes' the patrol; the laps are numbered without a count."""
    r = flown(A, B, jump(1, -1), {"command": "NAV_RETURN_TO_LAUNCH"}, extra={"time_limit_s": 60})
    program = r.plan.program
    assert r.problems == () and program is not None
    assert program.never_ends and program.patrol_item == 3
    steps = items(r)
    assert steps[:4] == [1, 2, 1, 2] and 4 not in steps  # the RTL after it is never reached
    # a lap is 5 + 7.07 m, at least 20 s at 0.6 m/s: 60 s needs > 3 laps, and one more
    laps = len(steps) // 2
    pts = points(r.plan)
    lower_s = sum(math.dist(p, q) for p, q in itertools.pairwise(pts)) / 0.6
    assert lower_s > 60.0 and laps >= 4
    assert program.lap_starts == tuple(range(2, len(steps), 2))
    assert program.first_lap() == (0, 2)
    assert program.steps[-1].forever and r.plan.waypoints[-1].stop
    assert program.laps()[:4] == ("lap 1", "lap 1", "lap 2", "lap 2")
    assert "(after DO_JUMP item 3, lap 2, forever)" in program.steps[2].text
    assert "flown until it is stopped" in program.ending and "60 s" in program.ending
    assert any("item 4 NAV_RETURN_TO_LAUNCH: never run" in n for n in r.notes)


def test_a_patrol_too_long_to_unroll_holds_after_its_planned_laps_and_says_so() -> None:
    r = flown(A, B, jump(1, -1), extra={"time_limit_s": 86_400})
    program = r.plan.program
    assert program is not None and len(program.steps) == PATROL_STEPS_MAX
    assert program.steps[-1].forever
    assert program.ending.endswith(
        f"{PATROL_STEPS_MAX // 2} laps planned, all a plan holds ({PATROL_STEPS_MAX} steps); "
        "then it holds where it is"
    )


def test_a_jump_to_a_missing_item_ends_the_mission_there() -> None:
    r = flown(A, jump(9, 1), B)
    assert items(r) == [1]  # AP_Mission: get_next_cmd fails → complete()
    assert any("item 9, which is not in the mission" in n for n in r.notes)
    assert any("item 3" in n and "never run" in n for n in r.notes)


def test_do_jump_tag_jumps_to_the_first_jump_tag_with_its_tag() -> None:
    tag = {"command": "JUMP_TAG", "tag": 7}
    r = flown(A, tag, B, {"command": "DO_JUMP_TAG", "tag": 7, "repeat": 2}, C)
    assert items(r) == [1, 3, 3, 3, 5]


def test_do_items_start_when_the_navigation_item_before_them_completes() -> None:
    servo = {"command": "DO_SET_SERVO", "channel": 9, "pwm_us": 1900}
    r = flown(A, servo, B)
    assert r.plan.program is not None
    step_a, step_b = r.plan.program.steps
    assert step_a.actions == ()
    (action,) = step_b.actions  # started with the leg A → B
    assert action.kind is ActionKind.SEND and action.item == 2
    assert action.params == (9.0, 1900.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def test_the_do_chain_stops_at_any_navigation_item_even_one_rover_skips() -> None:
    """advance_current_do_cmd stops at the next navigation command of any kind: a relay after
    a NAV_TAKEOFF (which Rover passes over) is never run."""
    servo = {"command": "DO_SET_SERVO", "channel": 9, "pwm_us": 1900}
    relay = {"command": "DO_SET_RELAY", "relay": 0, "state": 1}
    r = flown(A, servo, {"command": "NAV_TAKEOFF"}, relay, B)
    assert r.plan.program is not None
    step_b = r.plan.program.steps[1]
    assert [a.item for a in step_b.actions] == [2]
    assert any("item 4 DO_SET_RELAY" in n and "never run" in n for n in r.notes)
    assert any("item 3 NAV_TAKEOFF" in n and "skipped" in n for n in r.notes)
    assert step_b.skipped and "NAV_TAKEOFF" in step_b.skipped[0]


def test_the_first_do_item_after_the_last_waypoint_still_runs() -> None:
    """The scan that finds no navigation item left started the do item it met first."""
    r = flown(A, {"command": "DO_SET_SERVO", "channel": 9, "pwm_us": 1100},
              {"command": "DO_SET_SERVO", "channel": 10, "pwm_us": 1100})  # fmt: skip
    assert r.plan.program is not None
    assert [a.item for a in r.plan.program.final_actions] == [2]
    assert any("item 3" in n and "never run" in n for n in r.notes)


def test_hold_makes_the_waypoint_a_stop_and_keeps_whole_seconds() -> None:
    r = flown(A, {**B, "hold_s": 5}, C)
    assert [w.stop for w in r.plan.waypoints] == [False, True, False]
    assert r.plan.program is not None
    assert [s.hold_s for s in r.plan.program.steps] == [0.0, 5.0, 0.0]
    raw = flown(A, {**B, "command": "NAV_WAYPOINT", "params": [2.7, 0, 0, None]}, C)
    assert raw.plan.program is not None and raw.plan.program.steps[1].hold_s == 2.0


def test_here_means_where_the_rover_is_when_the_item_starts() -> None:
    here = {"command": "NAV_WAYPOINT", "hold_s": 4}  # lat/lon 0, 0 in a ground-station file
    r = flown(A, here, B)
    assert points(r.plan) == [(5, 0), (5, 5)]
    assert r.plan.waypoints[0].stop  # the rover stops where it is for the hold
    assert r.plan.program is not None
    step = r.plan.program.steps[1]
    assert step.first_waypoint is None and step.hold_s == 4.0
    assert step.text == "NAV_WAYPOINT stays where it is, at (5.00, 0.00), hold 4 s"


def test_nav_delay_stops_in_place() -> None:
    r = flown(A, {"command": "NAV_DELAY", "delay_s": 12}, B)
    assert r.plan.program is not None and r.plan.program.steps[1].hold_s == 12.0
    assert r.plan.waypoints[0].stop
    clock = flown(A, {"command": "NAV_DELAY", "delay_s": -1, "hour": 12}, B)
    assert any("time of day" in p for p in clock.problems)


def test_loiter_time_stops_and_waits() -> None:
    r = flown(A, {"command": "NAV_LOITER_TIME", "x": 5, "y": 5, "hold_s": 30}, C)
    assert r.plan.waypoints[1].stop
    assert r.plan.program is not None and r.plan.program.steps[1].hold_s == 30.0


def test_loiter_unlimited_is_refused_for_run() -> None:
    r = flown(A, {"command": "NAV_LOITER_UNLIM", "x": 5, "y": 5}, C)
    assert items(r) == [1, 2]
    assert any("NAV_LOITER_UNLIM" in p and "operator" in p for p in r.problems)


def test_loiter_unlimited_holds_and_goes_on_where_an_operator_can_continue() -> None:
    """helixd serve: DO_PAUSE_CONTINUE 1 ends the hold, and the mission goes on after it."""
    r = flown(A, {"command": "NAV_LOITER_UNLIM", "x": 5, "y": 5}, C,
              options=ExpandOptions(operator_continue=True))  # fmt: skip
    assert r.problems == () or list(r.problems) == []
    assert items(r) == [1, 2, 3]
    assert r.plan.program is not None and r.plan.program.steps[1].forever
    assert not r.plan.program.never_ends
    assert r.plan.waypoints[1].stop


def test_return_to_launch_goes_home_and_set_home_moves_it() -> None:
    r = flown(A, {"command": "NAV_RETURN_TO_LAUNCH"}, where=Where(home_xy_m=(1.0, -1.0)))
    assert points(r.plan)[-1] == (1.0, -1.0) and r.plan.waypoints[-1].stop
    moved = flown(A, {"command": "DO_SET_HOME", "use_current": 1}, B,
                  {"command": "NAV_RETURN_TO_LAUNCH"})  # fmt: skip
    assert points(moved.plan)[-1] == (5, 0)  # home where the rover was when item 2 ran
    assert moved.plan.program is not None
    (send,) = moved.plan.program.steps[1].actions
    assert send.kind is ActionKind.SEND and send.params[0] == 1.0


def test_set_home_with_a_place_needs_a_global_mission() -> None:
    m = mission(A, {"command": "DO_SET_HOME", "x": 1, "y": 1}, B)
    r = resolve(m, CFG.control, CFG.mission)
    assert any("global" in p for p in r.problems)


def test_speed_changes_are_bounded_and_minus_one_is_no_change() -> None:
    r = flown(
        A,
        {"command": "DO_CHANGE_SPEED", "speed_mps": 0.3},
        B,
        {"command": "DO_CHANGE_SPEED", "speed_mps": 5.0},
        C,
        {"command": "DO_CHANGE_SPEED", "speed_mps": -1},
        {"x": 0, "y": 0},
    )
    assert r.plan.program is not None
    assert [s.speed_mps for s in r.plan.program.steps] == [0.6, 0.3, 0.6, 0.6]
    assert any("bounded to 0.60 m/s by control.max_speed_mps" in n for n in r.notes)
    kinds = [a.kind for a in r.plan.program.steps[3].actions]
    assert kinds == [ActionKind.NOTE]  # -1: no change, as AR_WPNav::set_speed_max refuses it
    assert r.plan.peak_speed_mps == 0.6
    assert r.plan.leg_speeds_mps() == [0.6, 0.3, 0.6, 0.6]


def test_conditions_are_kept_in_the_chain() -> None:
    r = flown(A, {"command": "CONDITION_DELAY", "delay_s": 3},
              {"command": "DO_SET_SERVO", "channel": 9, "pwm_us": 1900}, B)  # fmt: skip
    assert r.plan.program is not None
    kinds = [a.kind for a in r.plan.program.steps[1].actions]
    assert kinds == [ActionKind.WAIT_TIME, ActionKind.SEND]


def test_loiter_turns_flies_a_circle_from_its_nearest_point() -> None:
    r = flown({"x": 20, "y": 0}, {"command": "NAV_LOITER_TURNS", "x": 10, "y": 0,
                                  "turns": 1, "radius_m": -5})  # fmt: skip
    pts = r.plan.waypoints[1:]
    assert (pts[0].x_m, pts[0].y_m) == pytest.approx((15.0, 0.0))  # nearest point to (20, 0)
    assert all(math.hypot(w.x_m - 10, w.y_m) == pytest.approx(5.0) for w in pts)
    # counter-clockwise (negative radius): the second corner is to the left (+y)
    assert pts[1].y_m > 0
    assert (pts[-1].x_m, pts[-1].y_m) == pytest.approx((15.0, 0.0))
    assert r.plan.program is not None
    step = r.plan.program.steps[1]
    assert (step.first_waypoint, step.last_waypoint) == (1, len(r.plan.waypoints) - 1)


def test_skipped_items_are_listed_and_strict_refuses_them() -> None:
    entries = ({"command": "NAV_TAKEOFF"}, A, {"command": "DO_SET_ROI_NONE"}, B)
    r = flown(*entries)
    assert r.problems == ()
    assert any(n.startswith("item 1 NAV_TAKEOFF: skipped, as ArduPilot Rover") for n in r.notes)
    assert any(n.startswith("item 3 DO_SET_ROI_NONE: ignored") for n in r.notes)
    strict = flown(*entries, options=ExpandOptions(strict=True))
    assert any("item 1 NAV_TAKEOFF" in p and "--strict" in p for p in strict.problems)
    assert any("item 3 DO_SET_ROI_NONE" in p and "--strict" in p for p in strict.problems)


def test_what_helixd_cannot_fly_is_refused_or_passed_over() -> None:
    guided = {"command": "NAV_GUIDED_ENABLE", "enable": 1}
    r = flown(A, guided, B)
    assert any("item 2 NAV_GUIDED_ENABLE" in p and "--skip-unsupported" in p for p in r.problems)
    passed = flown(A, guided, B, options=ExpandOptions(skip_unsupported=True))
    assert passed.problems == () and items(passed) == [1, 2, 3]
    unknown = flown(A, {"command": 31000}, B)
    assert any("MAV_MISSION_UNSUPPORTED" in p for p in unknown.problems)


def test_a_loop_over_do_items_only_is_refused() -> None:
    servo = {"command": "DO_SET_SERVO", "channel": 9, "pwm_us": 1900}
    r = flown(A, servo, jump(2, 1), B)
    assert any("loops over do items only" in p for p in r.problems)


def test_global_missions_keep_lat_lon_for_the_commands_they_send() -> None:
    m = Mission.model_validate(
        {
            "name": "g",
            "mode": "roll",
            "frame": "global",
            "waypoints": [
                {"lat": 53.5233, "lon": -113.5263},
                {"command": "DO_SET_HOME", "lat": 53.5234, "lon": -113.5262},
                {"lat": 53.5235, "lon": -113.5263},
                {"command": "NAV_RETURN_TO_LAUNCH"},
            ],
        }
    )
    r = resolve(m, CFG.control, CFG.mission, (53.5233, -113.5263))
    assert r.problems == ()
    assert r.plan.program is not None
    (send,) = r.plan.program.steps[1].actions
    assert send.params[4:6] == (53.5234, -113.5262) and send.params[0] == 0.0
    home = r.plan.waypoints[-1]
    assert (home.y_m, home.x_m) == pytest.approx((11.13, 6.62), abs=0.01)  # north, east


def test_every_speed_the_program_may_set_is_under_the_peak() -> None:
    """A faster change followed by a slower one in the same chain still bounds the plan's peak
    speed (the navigator is set to each in turn)."""
    r = flown(
        A,
        {"command": "DO_CHANGE_SPEED", "speed_mps": 0.2},
        B,
        {"command": "DO_CHANGE_SPEED", "speed_mps": 0.5},
        {"command": "DO_CHANGE_SPEED", "speed_mps": 0.25},
        C,
        extra={"speed_mps": 0.4},
    )
    assert r.plan.program is not None
    assert [s.speed_mps for s in r.plan.program.steps] == [0.4, 0.2, 0.25]
    assert r.plan.peak_speed_mps == 0.5


# -- a start at a later item (serve's AUTO from the autopilot's current item) ------------------


def from_item(k: int, *entries: dict[str, Any], where: Where | None = None) -> Resolved:
    return flown(*entries, options=ExpandOptions(first_item=k), where=where)


def test_a_start_at_item_k_walks_from_k_and_a_later_jump_still_goes_back() -> None:
    """AP_Mission::set_current_cmd(k) then resume: the walk begins at item k; the DO_JUMP
    after it still jumps back to item 1 (before k), with its counter from zero."""
    r = from_item(2, A, B, C, jump(1, 1))  # items 1..4
    assert items(r) == [2, 3, 1, 2, 3]
    assert points(r.plan)[0] == (5, 5)  # the first leg goes from where the rover is to item 2
    assert r.problems == ()
    assert not any("not run" in n or "never run" in n for n in r.notes)  # item 1 is flown


def test_a_start_inside_a_loop_counts_the_jump_from_zero() -> None:
    """_jump_tracking is cleared by AP_Mission::reset (a disarm outside AUTO) and by
    set_current_cmd on a completed mission: the loop runs its full repeat count from k."""
    r = from_item(3, A, B, C, jump(2, 2), {"x": 9, "y": 9})  # jump at item 4 back to item 2
    assert items(r) == [3, 2, 3, 2, 3, 5]


def test_do_items_before_k_are_not_run_and_the_speed_is_the_cruise_speed() -> None:
    """A DO_CHANGE_SPEED and a DO_SET_SERVO before k are not run (set_current_cmd starts the
    walk at k; ModeAuto::_enter's AR_WPNav::init sets the speed back to WP_SPEED); one after
    k is run with the leg after it."""
    slow = {"command": "DO_CHANGE_SPEED", "speed_mps": 0.3}
    servo = {"command": "DO_SET_SERVO", "channel": 9, "pwm_us": 1900}
    slower = {"command": "DO_CHANGE_SPEED", "speed_mps": 0.2}
    r = from_item(4, A, slow, servo, B, slower, C)  # items 1..6
    program = r.plan.program
    assert program is not None and r.problems == ()
    assert items(r) == [4, 6]
    assert [s.speed_mps for s in program.steps] == [0.6, 0.2]
    assert program.steps[0].actions == ()
    assert [a.item for a in program.steps[1].actions] == [5]
    assert any("item 2 DO_CHANGE_SPEED: before the start at item 4: not run" in n for n in r.notes)
    assert any("item 3 DO_SET_SERVO: before the start at item 4: not run" in n for n in r.notes)


def test_a_start_at_a_do_item_starts_it_with_the_next_navigation_item() -> None:
    """advance_current_nav_cmd(k) with k a do item: it is started with the navigation item
    after it (set_current_cmd on a DO item)."""
    slow = {"command": "DO_CHANGE_SPEED", "speed_mps": 0.3}
    r = from_item(2, A, slow, B, C)
    program = r.plan.program
    assert program is not None
    assert items(r) == [3, 4]
    assert [a.item for a in program.steps[0].actions] == [2]
    assert [s.speed_mps for s in program.steps] == [0.3, 0.3]


def test_a_start_at_the_first_item_is_the_whole_mission() -> None:
    whole = flown(A, B, jump(1, 1), C)
    first = from_item(1, A, B, jump(1, 1), C)
    assert items(first) == items(whole) == [1, 2, 1, 2, 4]
    assert points(first.plan) == points(whole.plan)


def test_the_jump_counters_the_autopilot_holds_carry_on_from_k() -> None:
    """resume / set_current_cmd keep _jump_tracking: a start at item 3 on the loop's second
    lap (the jump at item 4 taken once) flies the rest of the whole walk, not a full loop."""
    entries = (A, B, C, jump(2, 2), {"x": 9, "y": 9})  # items 1..5
    whole = items(flown(*entries))
    assert whole == [1, 2, 3, 2, 3, 2, 3, 5]
    m = mission(*entries)
    taken = jumps_when_current(m.waypoints, ExpandOptions(), 5, 3)
    assert taken == ((4, 1),)
    later = flown(*entries, options=ExpandOptions(first_item=3, jumps_taken=taken))
    assert items(later) == whole[4:] == [3, 2, 3, 5]


def test_jumps_when_current_finds_the_autopilots_item_at_or_after_helixds_step() -> None:
    m = mission(A, B, C, jump(2, 2), {"x": 9, "y": 9})
    assert jumps_when_current(m.waypoints, ExpandOptions(), 1, 3) == ()  # first lap
    assert jumps_when_current(m.waypoints, ExpandOptions(), 4, 3) == ((4, 1),)  # ahead of 4
    assert jumps_when_current(m.waypoints, ExpandOptions(), 6, 3) == ((4, 2),)
    assert jumps_when_current(m.waypoints, ExpandOptions(), 6, 5) == ()  # the jump finished
    assert jumps_when_current(m.waypoints, ExpandOptions(), 8, 2) == ()  # never again
    # from a walk that itself started later, with counters
    later = ExpandOptions(first_item=3, jumps_taken=((4, 1),))
    assert jumps_when_current(m.waypoints, later, 2, 2) == ((4, 2),)


def test_walk_at_step_names_the_item_and_the_counters_held_there() -> None:
    m = mission(A, B, C, jump(2, 2), {"x": 9, "y": 9})  # walk 1 2 3 2 3 2 3 5
    walk = [walk_at_step(m.waypoints, ExpandOptions(), n) for n in range(1, 10)]
    assert [w[0] if w else None for w in walk] == [1, 2, 3, 2, 3, 2, 3, 5, None]
    assert walk[3] == (2, ((4, 1),))
    assert walk[5] == (2, ((4, 2),))
    assert walk[7] == (5, ())  # the jump finished: its counter reset
    assert walk_at_step(m.waypoints, ExpandOptions(), 0) is None
    # a set current item keeps the counters: item 2 set on the second lap (the jump taken
    # once of twice) flies one lap more, not two
    later = flown(
        A,
        B,
        C,
        jump(2, 2),
        {"x": 9, "y": 9},
        options=ExpandOptions(first_item=2, jumps_taken=walk[3][1]),
    )
    assert items(later) == [2, 3, 2, 3, 5]


SLOW = {"command": "DO_CHANGE_SPEED", "speed_mps": 0.3}
BACK = {"command": "DO_SET_REVERSE", "reverse": 1}
D = {"x": 9, "y": 9}
# do items before a jump before the navigation item: the jump is counted after the do item
SPEED_JUMP = (A, SLOW, {"command": "DO_JUMP", "item": 5, "repeat": 1}, B, C, jump(1, 1))


@pytest.mark.parametrize(
    "entries",
    [
        (A, SLOW, B, C, jump(2, 1), D),
        (A, B, jump(2, 1), C, jump(1, 1)),  # nested: the inner counter reset by the outer
        SPEED_JUMP,
        (A, BACK, B, SLOW, C, jump(2, 2), D),
    ],
)
def test_a_walk_restarted_at_any_step_flies_the_rest_of_the_walk(
    entries: tuple[dict[str, Any], ...],
) -> None:
    """Started again at step n (at its first do item, with the counters held there), the walk
    flies exactly steps n.. of the whole walk, with the same do items started."""
    m = mission(*entries)
    whole = flown(*entries).plan.program
    assert whole is not None
    for n in range(1, len(whole.steps) + 1):
        at = restart_at_step(m.waypoints, ExpandOptions(), n)
        assert at is not None
        rest = flown(*entries, options=ExpandOptions(first_item=at[0], jumps_taken=at[1]))
        program = rest.plan.program
        assert program is not None and rest.problems == ()
        assert [s.item for s in program.steps] == [s.item for s in whole.steps[n - 1 :]]
        got = [[(a.item, a.kind) for a in s.actions] for s in program.steps]
        assert got == [[(a.item, a.kind) for a in s.actions] for s in whole.steps[n - 1 :]]
    assert restart_at_step(m.waypoints, ExpandOptions(), len(whole.steps) + 1) is None
    assert restart_at_step(m.waypoints, ExpandOptions(), 0) is None


def test_a_restart_starts_at_the_steps_first_do_item_with_the_counters_held_there() -> None:
    m = mission(A, SLOW, B, C, jump(2, 1), D)  # walk 1 3 4 3 4 6; item 2 starts with item 3
    assert [restart_at_step(m.waypoints, ExpandOptions(), n) for n in range(1, 7)] == [
        (1, ()),
        (2, ()),
        (4, ()),
        (2, ((5, 1),)),  # second lap: the jump taken once (walk_at_step says the same)
        (4, ((5, 1),)),
        (6, ()),
    ]
    assert walk_at_step(m.waypoints, ExpandOptions(), 4) == (3, ((5, 1),))
    # a jump between the do item and its navigation item is not counted yet: the restarted
    # walk takes it again (with the counters at the navigation item it would not jump)
    m = mission(*SPEED_JUMP)  # walk 1 5 1 4 5
    assert walk_at_step(m.waypoints, ExpandOptions(), 2) == (5, ((3, 1),))
    assert restart_at_step(m.waypoints, ExpandOptions(), 2) == (2, ())
    # a walk that itself started later: its steps count from its start, its counters too
    later = ExpandOptions(first_item=2, jumps_taken=((5, 1),))
    m = mission(A, SLOW, B, C, jump(2, 1), D)  # walk from item 2: 3 4 6
    assert restart_at_step(m.waypoints, later, 2) == (4, ((5, 1),))
    assert restart_at_step(m.waypoints, later, 3) == (6, ())


def test_the_speed_and_direction_carried_are_those_before_the_steps_own_items() -> None:
    r = flown(A, BACK, B, SLOW, C, D)  # steps: 1, 3 (reverse), 5 (0.3 m/s), 6
    program = r.plan.program
    assert program is not None
    opts = ExpandOptions()
    carried = [carried_at_step(program, n, opts) for n in range(1, 6)]
    assert carried == [(None, False), (None, False), (None, True), (0.3, True), (0.3, True)]
    # a walk that started with a speed and direction carries them until changed
    started = ExpandOptions(speed_mps=0.5, reverse=True)
    assert carried_at_step(program, 1, started) == (0.5, True)
    assert carried_at_step(program, 4, started) == (0.3, True)


def test_a_walk_starts_by_setting_the_speed_and_direction_it_carries() -> None:
    r = flown(A, B, SLOW, C, options=ExpandOptions(speed_mps=0.4, reverse=True))
    program = r.plan.program
    assert program is not None and r.problems == ()
    first, second, third = program.steps
    assert [(a.kind, a.value) for a in first.actions] == [
        (ActionKind.SPEED, 0.4),
        (ActionKind.REVERSE, 1.0),
    ]
    assert "carried on" in first.actions[0].text
    assert (first.speed_mps, second.speed_mps, second.actions) == (0.4, 0.4, ())
    assert third.speed_mps == 0.3  # the mission's own DO_CHANGE_SPEED still counts
    plain = flown(A, B, SLOW, C).plan.program
    assert plain is not None and plain.steps[0].actions == ()
    assert plain.steps[0].speed_mps == 0.6  # the configured cruise speed
