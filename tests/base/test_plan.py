"""helixd.base.plan: the operator's waypoint numbers (1-based, via points not counted)."""

from __future__ import annotations

from helixd.base.plan import Numbering, operator_numbers, waypoint_label


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
