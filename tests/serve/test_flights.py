"""helixd.serve.service: what the ground station reads when a flight ends."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from helixd.base.plan import Numbering
from helixd.base.run_files import EVENTS_FILE
from helixd.mission.expand import ExpandOptions
from helixd.recorder.summary import RunSummary
from helixd.runtime.prepare import AutoWalk
from helixd.serve.flights import flight_end_text, held_walk


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


def _events(run_dir: Path, *events: dict[str, Any]) -> None:
    run_dir.mkdir()
    text = "".join(json.dumps(ev) + "\n" for ev in events)
    (run_dir / EVENTS_FILE).write_text(text + "{torn", encoding="utf-8")


def test_the_walk_held_is_where_the_autopilots_own_item_was(tmp_path: Path) -> None:
    opts = ExpandOptions(first_item=3)
    started = [{"event": "mission_step", "kind": "step_started", "step": n} for n in (1, 2, 3)]
    helixd_only = tmp_path / "a"
    _events(helixd_only, *started)
    assert held_walk(("f", opts, helixd_only), "f") == AutoWalk(opts, 3, exact=False)
    assert held_walk(("f", opts, helixd_only), "other mission") is None
    assert held_walk(None, "f") is None
    followed = tmp_path / "b"
    _events(
        followed,
        *started,
        {"event": "autopilot_step", "item": 4, "step": 4},
        {"event": "autopilot_step", "item": 3, "step": "5"},  # garbled: ignored
    )
    assert held_walk(("f", opts, followed), "f") == AutoWalk(opts, 4, exact=True)
    item_set = tmp_path / "c"
    _events(
        item_set,
        *started,
        {"event": "autopilot_step", "item": 4, "step": 2},
        {"event": "autopilot_item_set", "item": 1, "autopilot_step": 2},
    )
    assert held_walk(("f", opts, item_set), "f") == AutoWalk(opts, 2, exact=True)
