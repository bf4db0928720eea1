"""helixd.base.plan: the operator's waypoint numbers (1-based, via points not counted)."""

from __future__ import annotations

from helixd.base.plan import (
    MissionFrameKind,
    MotionMode,
    NavStep,
    Numbering,
    Plan,
    PlanWaypoint,
    Program,
    operator_numbers,
    program_numbering,
    waypoint_label,
)


def test_operator_numbers_skip_via_points() -> None:
    vias = [True, True, False, True, False, False]
    assert operator_numbers(vias) == (1, 1, 1, 2, 2, 3)
    assert operator_numbers(vias, first=5) == (5, 5, 5, 6, 6, 7)


def test_labels_name_via_points_by_the_waypoint_they_lead_to() -> None:
    n = Numbering.of([True, False, True, False])
    assert [n.label(i) for i in range(4)] == ["via → 1/2", "1/2", "via → 2/2", "2/2"]
    assert n.operator_count == 2 and n.total == 2
    assert waypoint_label(3, False) == "3" and waypoint_label(3, True) == "via → 3"


def test_a_resumed_run_continues_the_whole_missions_count() -> None:
    n = Numbering.of([False, True, False], first=3, total=5)
    assert [n.label(i) for i in range(3)] == ["3/5", "via → 4/5", "4/5"]
    assert n.number(99) == 4 and n.via(-1) is False  # clamped, as target indexes are


def step(item: int, first: int | None, last: int | None) -> NavStep:
    return NavStep(item, 16, first, last, 0.0, (), 0.6, f"item {item}")


def test_a_program_is_numbered_by_its_items_with_the_laps_of_a_jump() -> None:
    # items 1, 2 (a circle of three points), 3 in place, a jump back to 1 once, item 5
    steps = (
        step(1, 0, 0), step(2, 1, 3), step(3, None, None),
        step(1, 4, 4), step(2, 5, 7), step(3, None, None), step(5, 8, 8),
    )  # fmt: skip
    wps = tuple(PlanWaypoint(float(i), 0.0, 0.5) for i in range(9))
    program = Program(steps, items_total=5)
    plan = Plan("t", MotionMode.ROLL, MissionFrameKind.START, wps, 0.6, program=program)
    n = program_numbering(plan)
    assert n is not None and n.items and n.total == 5
    assert n.numbers == (1, 2, 2, 2, 1, 2, 2, 2, 5)
    assert program.laps()[2:4] == ("lap 1 of 2", "lap 2 of 2")
    assert n.label(0) == "1/5 (lap 1 of 2)" and n.label(6) == "2/5 (lap 2 of 2)"
    assert n.label(8) == "5/5" and n.lap(99) == ""
    assert waypoint_label(3, True, 5, "lap 2 of 3") == "via → 3/5 (lap 2 of 3)"
    # the total never below a number shown, whatever the program says of its items
    short = Plan("t", MotionMode.ROLL, MissionFrameKind.START, wps, 0.6, program=Program(steps))
    got = program_numbering(short)
    assert got is not None and got.total == 5
    plain = Plan("t", MotionMode.ROLL, MissionFrameKind.START, wps, 0.6)
    assert program_numbering(plain) is None
