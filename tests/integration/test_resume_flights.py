"""`helixd run --resume RUN_DIR` over UDP against the built-in simulator, on the simulated
clock: a mission interrupted
by an injected fault is continued from its first waypoint not reached, re-entering the
interrupted leg, and completes — checked from the simulator's side (true pose)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.prepare.builder import Resume
from helixd.sim.snapshot import SimSnapshot
from tests.support.daemon import spawn_daemon
from tests.support.harness import secured
from tests.support.simulated import Steer, simulated_flight, simulated_flights

pytestmark = pytest.mark.integration

# local_ned (x east, y north): north 6 → corner → north 12 → corner (north 12, east 12)
MISSION = """name: resume-lane
mode: roll
frame: local_ned
waypoints:
- {north: 6.0, east: 0.0}
- {north: 6.0, east: 6.0}
- {north: 12.0, east: 6.0}
- {north: 12.0, east: 12.0}
"""
LAST_NE_M = (12.0, 12.0)
ARRIVAL_M = 1.0  # the default waypoint tolerance


def _json(path: Path) -> Any:
    return json.loads(path.read_text(encoding="utf-8"))


def _events(run_dir: Path) -> list[dict[str, Any]]:
    out = []
    for line in (run_dir / "events.jsonl").read_text(encoding="utf-8").splitlines():
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError:
            continue
    return out


def on_the_third_leg(s: SimSnapshot) -> bool:
    """Going north from 6 to 12 on east 6: waypoints 0 and 1 reached."""
    return s.armed and s.north_m > 8.0 and abs(s.east_m - 6.0) < 1.5


async def interrupt(st: Steer) -> SimSnapshot:
    """An EKF fault on the third leg; the autopilot once the run ended."""
    await st.until(on_the_third_leg, 90.0)
    st.inject("ekf_unhealthy", duration_s=2.0)
    await st.until(secured, 20.0)
    await st.exited(30.0)
    return st.snapshot()


@pytest.mark.parametrize("reboot", [True, False], ids=["battery_swap", "still_armed_in_hold"])
def test_resume_after_fault_completes_the_remaining_waypoints(tmp_path: Path, reboot: bool) -> None:
    mission = tmp_path / "lane.yaml"
    mission.write_text(MISSION, encoding="utf-8")
    runs: list[Path] = []

    def resume_the_first() -> Resume:
        (run1,) = sorted(p for p in (tmp_path / "runs").iterdir() if p.is_dir())
        runs.append(run1)
        return Resume(run1, None)

    async def resumed(st: Steer) -> tuple[list[float], SimSnapshot]:
        crossings: list[float] = []

        def on_line_until_done(s: SimSnapshot) -> bool:
            if 6.0 + 1.0 < s.north_m < 12.0 - 1.0:
                crossings.append(abs(s.east_m - 6.0))
            return math.hypot(s.north_m - LAST_NE_M[0], s.east_m - LAST_NE_M[1]) < ARRIVAL_M

        await st.until(on_line_until_done, 90.0)
        await st.exited(30.0)
        return crossings, st.snapshot()

    async def then_reboot(st: Steer) -> SimSnapshot:
        stopped = await interrupt(st)
        # battery swap: the autopilot reboots (disarmed, INITIALISING); resume with the same
        # config once it is back. Without it the autopilot is still armed in HOLD: the new
        # run must see MANUAL in a HEARTBEAT before flying, or it reads HOLD as a takeover.
        if reboot:
            st.inject("reboot")
        return stopped

    first, second = simulated_flights(
        tmp_path, [(mission, then_reboot), (resume_the_first, resumed)]
    )
    (run1,) = runs
    stopped = first.steered
    assert first.code == ExitCode.FAULT, first.log[-3000:]
    s1 = _json(run1 / "summary.json")
    assert s1["completed"] is False and s1["waypoints_reached"] == 2, s1
    assert (run1 / "inputs.json").is_file()
    assert stopped.north_m < 12.0 - ARRIVAL_M
    if not reboot:
        assert stopped.armed and stopped.mode == "HOLD"
    crossings, end = second.steered
    code2, log2 = second.code, second.log
    run2 = second.outcome.run_dir
    assert run2 is not None
    assert code2 == ExitCode.OK, log2[-3000:]
    # exit 0 means disarmed, also when the run found the vehicle armed (still in HOLD)
    assert not end.armed and end.mode == "HOLD", (end.armed, end.mode)
    assert "from waypoint 3/4 (2 remaining)" in log2
    # the interrupted leg was re-entered along the surveyed line east = 6, not cut across
    assert crossings and max(crossings) < 0.6, max(crossings or [0.0])
    s2 = _json(run2 / "summary.json")
    assert s2["completed"] is True and s2["waypoints_total"] == 2
    assert s2["resumed_from"]["path"] == str(run1.resolve())
    assert s2["resumed_from"]["first_waypoint"] == 2
    assert (run2 / "mission.yaml").read_text().count("north:") == 2
    resumed_events = [e for e in _events(run2) if e.get("event") == "run_resumed"]
    assert len(resumed_events) == 1 and resumed_events[0]["first_waypoint"] == "3/4"
    reached = [e for e in _events(run2) if e.get("event") == "waypoint_reached"]
    assert [e.get("waypoint") for e in reached] == ["3/4", "4/4"]  # of the whole mission
    assert [e.get("index") for e in reached] == [0, 1]  # of this run's plan
    # the progress line counts waypoints of the whole mission, not of the remainder
    progress = [e.get("waypoint") for e in _events(run2) if e.get("event") == "progress"]
    assert progress and progress[0] == "3/4" and set(progress) <= {"3/4", "4/4"}
    # and the completed run cannot be resumed again
    args = ["run", "--resume", str(run2), "--config", str(tmp_path / "helixd.yaml")]
    again = spawn_daemon(
        [*args, "--run-dir", str(tmp_path / "runs3")], cwd=tmp_path, run_root=tmp_path / "runs3"
    )
    try:
        assert again.wait_exit(30.0) == ExitCode.USAGE
        assert "completed already" in again.log_text()
    finally:
        again.kill()


def test_a_resumed_simulator_run_starts_where_the_interrupted_one_stopped(tmp_path: Path) -> None:
    """`run --sim --resume RUN`: the built-in simulator puts the rover where the interrupted
    run left it (not at home), so a clean resume shows no approach error; the new run lands
    beside the interrupted one, whatever the working directory; run_resumed once."""
    mission = tmp_path / "lane.yaml"
    mission.write_text(MISSION, encoding="utf-8")
    first = simulated_flight(tmp_path, mission, during=interrupt)
    assert first.code == ExitCode.FAULT, first.log[-3000:]
    run1 = first.run_dir()
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    args = ["run", "--sim", "--sim-clock", "simulated", "--resume", str(run1),
            "--config", str(tmp_path / "helixd.yaml")]  # fmt: skip
    second = spawn_daemon(args, cwd=elsewhere, run_root=run1.parent)
    try:
        code2 = second.wait_exit(120.0)
        log2 = second.log_text()
        run2 = second.run_dir()
    finally:
        second.kill()
    assert code2 == ExitCode.OK, log2[-3000:]
    assert run2.parent == run1.parent and not (elsewhere / "runs").exists()
    last1 = _flight_rows(run1)[-1]
    first2 = _flight_rows(run2)[0]
    assert math.hypot(first2[0] - last1[0], first2[1] - last1[1]) < 0.5  # not home (0, 0)
    s2 = _json(run2 / "summary.json")
    assert s2["completed"] is True
    assert s2["cross_track_max_m"] < 0.5, s2  # no approach from home in it
    assert len([e for e in _events(run2) if e.get("event") == "run_resumed"]) == 1


def _flight_rows(run_dir: Path) -> list[tuple[float, float]]:
    """(north_m, east_m) of every flight.csv row."""
    lines = [x for x in (run_dir / "flight.csv").read_text().splitlines() if not x.startswith("#")]
    head = lines[0].split(",")
    n, e = head.index("north_m"), head.index("east_m")
    return [(float(c[n]), float(c[e])) for c in (x.split(",") for x in lines[1:])]
