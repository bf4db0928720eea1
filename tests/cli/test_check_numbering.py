"""``helixd check`` on ground-station missions with commands: the step table wraps its texts
at the terminal's width instead of cutting them, places are given from the same point as
``run`` gives them (and the header says which), and errors count entries from 1.

Before: at a narrow terminal the jump note was cut ("(after DO_JUMP item 6" without "1 of
2"); a loiter of a lat/lon mission read (8.00, 0.00) in ``check`` (from waypoint 1) and (8.00,
8.00) in ``run`` (from the EKF origin); errors named ``waypoints.0``."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from helixd.base.frames import ne_to_latlon
from helixd.base.plan import MotionMode
from helixd.config.root import HelixdConfig
from helixd.mission.formats import load_mission_file
from helixd.mission.resolve import Where, resolve
from tests.support.cli import run_main
from tests.support.paths import REPO_ROOT

CFG = HelixdConfig()
HOME = (53.523250, -113.526110)
NOTE = "(after DO_JUMP item 4, 1 of 2)"


def wpl(tmp_path: Path, name: str, rows: list[tuple[int, float, float, float, float]]) -> Path:
    """A WPL 110 file: home, then (command, param1, param2, north_m, east_m) from home per
    item (a command without a place: north_m = east_m = nan)."""
    lines = ["QGC WPL 110", f"0\t1\t0\t16\t0\t0\t0\t0\t{HOME[0]:.8f}\t{HOME[1]:.8f}\t668.0\t1"]
    for seq, (cmd, p1, p2, n, e) in enumerate(rows, start=1):
        lat, lon = (0.0, 0.0) if n != n else ne_to_latlon(n, e, *HOME)
        lines.append(f"{seq}\t0\t3\t{cmd}\t{p1}\t{p2}\t0\t0\t{lat:.8f}\t{lon:.8f}\t0.0\t1")
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


NAN = float("nan")
JUMPS = [(16, 0, 0, 6, 0), (16, 0, 0, 6, 10), (16, 0, 0, 16, 10), (177, 1, 2, NAN, NAN),
         (20, 0, 0, NAN, NAN)]  # fmt: skip
# waypoint 1 8 m north of home, a loiter 8 m east of it, then on
LOITER = [(16, 0, 0, 8, 0), (19, 5, 0, 8, 8), (16, 0, 0, 16, 8)]


def test_check_wraps_the_jump_note_at_a_narrow_terminal(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("COLUMNS", "60")
    path = wpl(tmp_path, "jumps.waypoints", JUMPS)
    code, out, err = run_main(["check", "--mission", str(path), "--mode", "roll"], capsys)
    assert code == 0, err
    table = out[out.index(" step ") :]
    lines = table.splitlines()
    assert any(ln.strip() == NOTE for ln in lines), table  # whole, on a line of its own
    assert any(ln.strip() == "(after DO_JUMP item 4, 2 of 2)" for ln in lines), table
    steps = [ln for ln in table.splitlines() if re.match(r"\s+\d+\s+\d+\s+\S", ln)]
    assert len(steps) == 10 and all(len(ln) <= 60 for ln in steps), table
    # numbered as the ground station numbers the items
    assert "mission items numbered as the ground station shows them" in out


def test_check_and_run_give_a_place_from_waypoint_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = wpl(tmp_path, "loiter.waypoints", LOITER)
    code, out, err = run_main(["check", "--mission", str(path), "--mode", "roll"], capsys)
    assert code == 0, err
    assert "axes    : x east / y north of waypoint 1 (metres)" in out
    assert "NAV_LOITER_TIME → (8.00, 0.00), hold 5 s" in out
    # run: the EKF origin at home, waypoint 1 8 m north of it; the plan is flown from the
    # origin, the steps say the place from waypoint 1 as check did
    mission = load_mission_file(path, mode=MotionMode.ROLL).mission
    where = Where(start_xy_m=(0.0, 0.0), home_xy_m=(0.0, 0.0))
    flown = resolve(mission, CFG.control, CFG.mission, HOME, where).plan
    assert flown.program is not None
    loiter = next(s for s in flown.program.steps if s.item == 2)
    assert loiter.text == "NAV_LOITER_TIME → (8.00, 0.00), hold 5 s"
    assert loiter.last_waypoint is not None
    wp = flown.waypoints[loiter.last_waypoint]
    assert (round(wp.x_m, 2), round(wp.y_m, 2)) == (8.0, 8.0)  # east, north of the origin


def test_errors_count_entries_from_1(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    yaml_path = tmp_path / "q.yaml"
    for name, first, said in [
        ("q", "{north: 1, east: 0, q: 3}", "waypoint 1 (waypoints[0]): q: unknown key"),
        ("far", "{north: 1, east: 0}", "waypoint 2 (waypoints[1]): (794.0, 0.0) is 794.0 m from"),
    ]:
        yaml_path.write_text(
            f"name: {name}\nmode: roll\nframe: local_ned\nwaypoints:\n"
            f"  - {first}\n  - {{north: 794, east: 0}}\n"
        )
        code, _, err = run_main(["check", "--mission", str(yaml_path)], capsys)
        assert code == 2
        assert f"{yaml_path}: {said}" in err, err
    # a ground-station file: its item, the sequence number QGroundControl shows
    far = wpl(tmp_path, "far.waypoints", [(16, 0, 0, 5, 0), (16, 0, 0, 5, 10), (16, 0, 0, 700, 0)])
    code, _, err = run_main(["check", "--mission", str(far), "--mode", "roll"], capsys)
    assert code == 2
    assert re.search(rf"{re.escape(str(far))}: item 3: 69\d\.\d m from", err), err
    assert "waypoints[" not in err and "waypoints." not in err


def test_check_accepts_a_patrol_and_says_what_its_estimate_and_limit_mean(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Three waypoints and a DO_JUMP with repeat -1 (a patrol the crew stops from the ground
    station) is flown as ArduPilot Rover flies it; check says one lap's time and that the time
    limit ends it, instead of refusing it or summing laps planned beyond the limit."""
    monkeypatch.setenv("COLUMNS", "120")
    path = wpl(
        tmp_path,
        "patrol.waypoints",
        [(16, 0, 0, 10.0, 0.0), (16, 0, 0, 10.0, 10.0), (16, 0, 0, 0.0, 10.0),
         (177, 1, -1, NAN, NAN)],
    )  # fmt: skip
    code, out, err = run_main(["check", "--mission", str(path), "--mode", "roll"], capsys)
    assert code == 0, err
    (estimate,) = [line for line in out.splitlines() if line.startswith("estimate:")]
    got = re.fullmatch(
        r"estimate: a patrol, flown until stopped: first lap done at (\d+) s from waypoint 1, "
        r"then (\d+) s a lap; limit safety\.mission_time_limit_s = 1800 s ends it after about "
        r"(\d+) laps \(fault mission_time, exit 4\) unless it is stopped before",
        estimate,
    )
    assert got is not None, estimate
    first_s, lap_s, laps = (int(g) for g in got.groups())
    assert 30 < first_s < lap_s < 120 and laps == round(1 + (1800 - first_s) / lap_s)
    assert "(after DO_JUMP item 4, lap 2, forever)" in out
    assert "ends: item 4 DO_JUMP repeats forever: a patrol flown until it is stopped" in out


def test_planned_legs_name_the_items_the_step_table_names(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """pond.plan: item 3 is a DO_SET_CAM_TRIGG_DIST, so its third place is item 4. The legs
    the planner prints are named by item, as the step table above them."""
    plan = str(REPO_ROOT / "config" / "missions" / "pond.plan")
    code, out, err = run_main(
        [
            "check",
            "--config",
            str(REPO_ROOT / "config" / "helixd.yaml"),
            "--mission",
            plan,
            "--mode",
            "scroll",
        ],
        capsys,
    )
    assert code == 0, out + err
    legs = [line.strip() for line in out.splitlines() if line.strip().startswith("leg ")]
    assert [leg.split(":")[0] for leg in legs] == [
        "leg start → item 1",
        "leg item 1 → item 2",
        "leg item 2 → item 4",
        "leg item 4 → item 5",
        "leg item 5 → item 6",
    ]
    assert "    3    4  NAV_WAYPOINT" in out  # the step table's third step: item 4
