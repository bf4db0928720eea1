"""helixd.runtime.serve: what the ground station reads when a flight ends."""

from __future__ import annotations

from helixd.base.plan import Numbering
from helixd.recorder.summary import RunSummary
from helixd.runtime.serve import flight_end_text

RESULT = "helixd: RESULT stopped paused: DO_PAUSE_CONTINUE 0 — 1/2 waypoints, 9.0 s, exit 5"


def test_a_resumed_flight_counts_in_the_ground_stations_numbering() -> None:
    # resumed from waypoint 2 of 3: 'reached WP 3/3' must not be followed by '2/2 waypoints'
    numbering = Numbering.of([False, False], first=2, total=3)
    summary = RunSummary.model_construct(rows=10, waypoints_reached=2)
    text = flight_end_text(summary, numbering, [RESULT])
    assert text == "3/3 waypoints"


def test_no_result_line_or_exit_code() -> None:
    numbering = Numbering.of([False, True, False])
    summary = RunSummary.model_construct(rows=10, waypoints_reached=1)
    text = flight_end_text(summary, numbering, [RESULT])
    assert text == "1/2 waypoints"


def test_a_flight_never_started_says_why() -> None:
    numbering = Numbering.of([False])
    summary = RunSummary.model_construct(rows=0, waypoints_reached=0)
    why = "preflight refused: EKF not healthy"
    assert flight_end_text(summary, numbering, [why, RESULT]) == why
    assert flight_end_text(None, numbering, [RESULT]) == "not flown"
