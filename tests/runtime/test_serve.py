"""helixd.runtime.serve: what the ground station reads when a flight ends."""

from __future__ import annotations

from typing import Any

from helixd.base.plan import Numbering
from helixd.recorder.summary import RunSummary
from helixd.runtime.serve import flight_end_text


def summary_of(rows: int, reached: int) -> RunSummary:
    values: dict[str, Any] = {"rows": rows, "waypoints_reached": reached}  # all it reads
    return RunSummary.model_construct(**values)


RESULT = "helixd: RESULT stopped paused: DO_PAUSE_CONTINUE 0 — 1/2 waypoints, 9.0 s, exit 5"


def test_a_resumed_flight_counts_in_the_ground_stations_numbering() -> None:
    # resumed from waypoint 2 of 3: 'reached WP 3/3' must not be followed by '2/2 waypoints'
    numbering = Numbering.of([False, False], first=2, total=3)
    summary = summary_of(rows=10, reached=2)
    text = flight_end_text(summary, numbering, [RESULT])
    assert text == "3/3 waypoints"


def test_no_result_line_or_exit_code() -> None:
    numbering = Numbering.of([False, True, False])
    summary = summary_of(rows=10, reached=1)
    text = flight_end_text(summary, numbering, [RESULT])
    assert text == "1/2 waypoints"


def test_a_flight_never_started_says_why() -> None:
    numbering = Numbering.of([False])
    summary = summary_of(rows=0, reached=0)
    why = "preflight refused: EKF not healthy"
    assert flight_end_text(summary, numbering, [why, RESULT]) == why
    assert flight_end_text(None, numbering, [RESULT]) == "not flown"


def test_a_patrol_ends_without_a_total_of_its_planned_laps() -> None:
    numbering = Numbering((1, 2, 1, 2), (False,) * 4, 3, items=True)
    values: dict[str, Any] = {
        "rows": 10, "waypoints_reached": 3, "waypoints_total": 40, "patrol_item": 3,
        "arrivals": (),
    }  # fmt: skip
    text = flight_end_text(RunSummary.model_construct(**values), numbering, [RESULT])
    assert text == "3 waypoints as flown (patrol)"
