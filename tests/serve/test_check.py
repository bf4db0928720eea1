"""helixd.serve.check: the service's verdict on a mission file and on the autopilot's
downloaded mission, each checked as ``helixd check`` checks it (nothing touches a link)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from helixd.base.plan import MotionMode
from helixd.config.root import HelixdConfig
from helixd.mission.formats import read_gcs
from helixd.mission.formats.wire import gcs_to_wire
from helixd.serve.check import MAX_REFUSAL_TEXTS, CheckInputs, check_download, check_file, plan_id
from helixd.serve.core import ServeState
from helixd.serve.options import SERVE_OPTIONS

HOME = (53.523250, -113.526110)
DEG_PER_M = 1 / 111_320.0
FINGERPRINT = "1a2b3c4d5e6f"


def waypoints_file(tmp_path: Path, *north_m: float, name: str = "mission") -> Path:
    """A ground station's .waypoints: home, then a waypoint ``north_m`` north of it each."""
    rows = [
        "QGC WPL 110",
        f"0\t1\t0\t16\t0\t0\t0\t0\t{HOME[0]:.8f}\t{HOME[1]:.8f}\t668.0\t1",
        *(
            f"{i}\t0\t3\t16\t0\t0\t0\t0\t{HOME[0] + n * DEG_PER_M:.8f}\t{HOME[1]:.8f}\t0.0\t1"
            for i, n in enumerate(north_m, start=1)
        ),
    ]
    path = tmp_path / f"{name}.waypoints"
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def _inputs(cfg: HelixdConfig | None = None, mode: MotionMode | None = None) -> CheckInputs:
    return CheckInputs(cfg or HelixdConfig(), None, mode, SERVE_OPTIONS, None)


def downloaded(path: Path) -> tuple[Any, ...]:
    return tuple(gcs_to_wire(read_gcs(path)).mission)


def test_a_mission_file_near_its_home_is_ready_and_named_by_its_file(tmp_path: Path) -> None:
    path = waypoints_file(tmp_path, 30.0, 50.0)
    fingerprint, verdict = check_file(path, _inputs(mode=MotionMode.ROLL))
    assert verdict.state is ServeState.READY
    assert verdict.detail == "mission.waypoints checked, 2 waypoints"
    checked = verdict.checked
    assert checked is not None and checked.fingerprint == fingerprint
    assert (checked.last_item, checked.waypoints) == (2, 2)
    assert check_file(path, _inputs(mode=MotionMode.ROLL))[0] == fingerprint  # the same file
    other = waypoints_file(tmp_path, 30.0, 60.0, name="other")
    assert check_file(other, _inputs(mode=MotionMode.ROLL))[0] != fingerprint


def test_a_refused_file_is_the_same_news_only_while_refused_alike(tmp_path: Path) -> None:
    path = waypoints_file(tmp_path, 794.0, 814.0)
    fingerprint, verdict = check_file(path, _inputs(mode=MotionMode.ROLL))
    assert verdict.state is ServeState.REFUSED and verdict.checked is None
    assert "794.0 m from the mission's home" in verdict.detail, verdict.detail
    assert verdict.problems[0] == verdict.detail
    assert fingerprint == "refused:" + "; ".join(verdict.problems)
    assert check_file(path, _inputs(mode=MotionMode.ROLL))[0] == fingerprint


def test_the_autopilots_mission_is_ready_under_its_plan_id(tmp_path: Path) -> None:
    mission = downloaded(waypoints_file(tmp_path, 30.0, 50.0, 70.0))
    verdict = check_download(mission, (), FINGERPRINT, _inputs(mode=MotionMode.ROLL))
    assert verdict.state is ServeState.READY
    checked = verdict.checked
    assert checked is not None
    assert (checked.last_item, checked.waypoints) == (3, 3)
    assert checked.name == f"{plan_id(FINGERPRINT)}: 3 waypoints" == "plan 1a2b3c: 3 waypoints"
    assert verdict.detail == "plan 1a2b3c: 3 waypoints checked"


def test_no_mission_on_the_autopilot_is_idle_not_refused(tmp_path: Path) -> None:
    home_only = downloaded(waypoints_file(tmp_path, 30.0))[:1]  # what a cleared autopilot holds
    verdict = check_download(home_only, (), FINGERPRINT, _inputs(mode=MotionMode.ROLL))
    assert (verdict.state, verdict.detail) == (ServeState.IDLE, "no mission on the autopilot")


def test_without_a_motion_mode_the_autopilots_mission_is_refused_and_says_where_to_set_it(
    tmp_path: Path,
) -> None:
    mission = downloaded(waypoints_file(tmp_path, 30.0))
    verdict = check_download(mission, (), FINGERPRINT, _inputs())
    assert verdict.state is ServeState.REFUSED
    assert "mission.ground_station_mode" in verdict.detail
    cfg = HelixdConfig.model_validate({"mission": {"ground_station_mode": "roll"}})
    assert check_download(mission, (), FINGERPRINT, _inputs(cfg)).state is ServeState.READY


def test_a_refusal_tells_the_ground_station_its_first_problems_only(tmp_path: Path) -> None:
    """Every problem goes to the log; the GCS gets the first as the state's text and at
    most MAX_REFUSAL_TEXTS in all, in the autopilot's item numbers."""
    far = downloaded(waypoints_file(tmp_path, *(800.0 + 10.0 * i for i in range(8))))
    verdict = check_download(far, (), FINGERPRINT, _inputs(mode=MotionMode.ROLL))
    assert verdict.state is ServeState.REFUSED and verdict.checked is None
    assert len(verdict.problems) > MAX_REFUSAL_TEXTS, verdict.problems
    assert len(verdict.more) == MAX_REFUSAL_TEXTS - 1
    assert all(t.startswith("refused: ") for t in verdict.more)
    assert "autopilot at" not in verdict.detail  # the source is the service's own


@pytest.mark.parametrize("mode", [MotionMode.ROLL, MotionMode.SCROLL])
def test_the_mode_asked_is_the_mode_flown(tmp_path: Path, mode: MotionMode) -> None:
    mission = downloaded(waypoints_file(tmp_path, 30.0))
    verdict = check_download(mission, (), FINGERPRINT, _inputs(mode=mode))
    assert verdict.checked is not None
    assert verdict.checked.flight.mission.mode is mode
