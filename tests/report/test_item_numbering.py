"""A ground-station mission with commands is numbered as the ground station numbers its items,
everywhere the operator reads a number: the progress line and event, ``waypoint_reached``, the
GCS texts, the sequencer's steps, summary.json and the result line.

Before: a QGroundControl ``.waypoints`` file with three waypoints, a DO_JUMP (repeat 2) and a
NAV_RETURN_TO_LAUNCH was reported as the expanded steps (``waypoint=1/7`` … ``8/7``), ending
"8/8 waypoints": neither the item numbers QGroundControl shows nor a total the count stays
under. Sequenced here purely (no simulator): the sequencer is stepped with each arrival the
navigator would report, in the plan's order."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from helixd.base.plan import MotionMode, Numbering, program_numbering
from helixd.config.recorder import GcsReportConfig
from helixd.config.root import HelixdConfig
from helixd.control.sequencer import Sequencer
from helixd.mission.formats import load_mission_file
from helixd.mission.resolve import Where, resolve
from helixd.recorder.summary import SummaryBuilder
from helixd.report.display import ProgressInfo, progress_fields, progress_line, result_line
from helixd.report.gcs_report import GcsReporter, WaypointReached
from helixd.serve.flights import flight_end_text

CFG = HelixdConfig()
HOME = (53.523250, -113.526110)
# home (row 0), items 1–3 waypoints, 4 DO_JUMP to item 1 twice (three laps), 5 RTL
WPL = """QGC WPL 110
0\t1\t0\t16\t0\t0\t0\t0\t53.523250\t-113.526110\t668.0\t1
1\t0\t3\t16\t0\t0\t0\t0\t53.52330000\t-113.52605000\t0.0\t1
2\t0\t3\t16\t0\t0\t0\t0\t53.52330000\t-113.52590000\t0.0\t1
3\t0\t3\t16\t0\t0\t0\t0\t53.52339000\t-113.52590000\t0.0\t1
4\t0\t3\t177\t1\t2\t0\t0\t0\t0\t0\t1
5\t0\t3\t20\t0\t0\t0\t0\t0\t0\t0\t1
"""
ITEMS = 5
RATIO = re.compile(r"(\d+)/(\d+)")


def numbers_shown(text: str) -> list[tuple[int, int]]:
    """Every "n/m" in a text the operator reads."""
    return [(int(a), int(b)) for a, b in RATIO.findall(text)]


def statustexts(msgs: list[Any]) -> list[str]:
    out = []
    for m in msgs:
        if m.get_type() == "STATUSTEXT":
            out.append(m.text if isinstance(m.text, str) else m.text.decode("ascii"))
    return out


def flown(tmp_path: Path) -> tuple[Any, Numbering]:
    path = tmp_path / "laps.waypoints"
    path.write_text(WPL)
    mission = load_mission_file(path, mode=MotionMode.ROLL).mission
    where = Where(start_xy_m=(0.0, 0.0), home_xy_m=(0.0, 0.0))
    resolved = resolve(mission, CFG.control, CFG.mission, HOME, where)
    assert resolved.problems == ()
    numbering = program_numbering(resolved.plan)
    assert numbering is not None
    return resolved.plan, numbering


def test_every_number_reported_is_a_mission_item_and_the_laps_are_stated(tmp_path: Path) -> None:
    plan, numbering = flown(tmp_path)
    program = plan.program
    assert [s.item for s in program.steps] == [1, 2, 3, 1, 2, 3, 1, 2, 3, 5]
    assert numbering.items and numbering.total == ITEMS

    seq = Sequencer(program)
    events = list(seq.start(0.0).events)
    gcs = GcsReporter(GcsReportConfig(), 0.0)
    summary = SummaryBuilder(waypoints_total=numbering.operator_count)
    shown: list[str] = []  # every text with a number the operator reads
    reached: list[str] = []
    for i in range(len(plan.waypoints)):
        t = 10.0 * (i + 1)
        info = ProgressInfo(
            waypoint_index=numbering.number(i),
            waypoints_total=numbering.total,
            distance_to_go_m=1.0,
            speed_mps=0.5,
            heading_error_deg=0.0,
            link_ok=True,
            pose_fresh=True,
            elapsed_s=t,
            via=numbering.via(i),
            lap=numbering.lap(i),
        )
        shown.append(str(progress_fields("fly", info)["waypoint"]))
        shown.append(progress_line("fly", info).plain.splitlines()[0])
        events += seq.update(t, i, 0.0).events
        reached.append(numbering.label(i))  # waypoint_reached's "waypoint"
        number, lap = numbering.number(i), numbering.lap(i)
        msgs = gcs.feed(WaypointReached(number - 1, numbering.total, lap), t)
        msgs += gcs.tick(t + 5.0)
        shown += statustexts(msgs)
        summary.arrival(i, t, 0.1, number=number, via=numbering.via(i), lap=lap)
    assert seq.done
    assert reached == [
        "1/5 (lap 1 of 3)", "2/5 (lap 1 of 3)", "3/5 (lap 1 of 3)",
        "1/5 (lap 2 of 3)", "2/5 (lap 2 of 3)", "3/5 (lap 2 of 3)",
        "1/5 (lap 3 of 3)", "2/5 (lap 3 of 3)", "3/5 (lap 3 of 3)",
        "5/5",
    ]  # fmt: skip
    assert "helixd: reached WP 2/5 (lap 3 of 3)" in shown
    assert any(" wp 3/5 (lap 2 of 3) " in text for text in shown)  # the console line

    # the sequencer's steps name the items, their laps as the program states them
    laps = program.laps()
    started = [(e.item, laps[e.step]) for e in events if e.kind == "step_started"]
    assert started[3] == (1, "lap 2 of 3")
    assert started[-1] == (5, "")
    assert all(1 <= item <= ITEMS for item, _ in started)

    built = summary.build(True, None, 0, items_total=numbering.total)
    assert (built.waypoints_reached, built.waypoints_total, built.items_total) == (10, 10, 5)
    assert [a.number for a in built.arrivals] == [1, 2, 3, 1, 2, 3, 1, 2, 3, 5]
    assert built.arrivals[4].lap == "lap 2 of 3"
    line = result_line(built)
    assert "10/10 waypoints as flown (mission items 1–5, DO_JUMP laps each counted)" in line
    end = flight_end_text(built.model_copy(update={"rows": 500}), numbering, [])
    assert end == "10/10 waypoints as flown, last item 5/5"
    shown += [line, end]

    ratios = [r for text in shown for r in numbers_shown(text)]
    assert ratios, shown
    # a count never above its total; an item never above the mission's item count
    assert all(n <= m for n, m in ratios), shown
    numbered = [text for text in shown if "waypoints as flown" not in text]
    items = [n for text in numbered for n, _ in numbers_shown(text)]
    assert all(1 <= n <= ITEMS for n in items), shown


def test_a_plain_list_of_waypoints_keeps_its_waypoint_numbers() -> None:
    numbering = Numbering.of([False, True, False])
    assert numbering.label(1) == "via → 2/2"
    assert not numbering.items and numbering.lap(0) == ""
