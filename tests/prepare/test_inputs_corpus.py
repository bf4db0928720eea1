"""Every mission file ArduPilot's Rover autotest and QGroundControl's mission tests carry
(tests/data/gcs, origins in its README) either checks — commands and all — or is refused with
one line that names the item (or the kind of file) and a reason ArduPilot Rover shares."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from helixd.base.plan import MotionMode
from helixd.prepare.inputs import InputsRefused, load_inputs
from tests.support.paths import DATA_DIR

GCS = DATA_DIR / "gcs"
ROLL = MotionMode.ROLL

# limits wide enough for the autotest fields (hundreds of metres) and QGC's 10 km SITL plan
WIDE = {
    "mission": {"max_range_m": 10_000, "max_start_distance_m": 10_000},
    "safety": {"mission_time_limit_s": 86_400, "geofence_radius_m": 10_000},
}

FLOWN = [
    "ap-CameraMission-rover-camera-mission.txt",
    "ap-DepthFinder-rover1.txt",
    "ap-DriveEachFrame-basic.txt",
    "ap-DriveMission-balancebot1.txt",
    "ap-DriveMission-rover1.txt",
    "ap-DriveRTL-rtl.txt",
    "ap-EndMissionBehavior-end-mission.txt",  # its only item is "here": done at once
    "ap-GripperMission-rover-gripper-mission.txt",
    "ap-PolyFenceObjectAvoidanceAuto-rover-path-planning-mission.txt",
    "ap-PolyFenceObjectAvoidanceBendyRulerEasierAuto-rover-path-bendyruler-mission-easier.txt",
    "ap-Sprayer-sprayer-mission.txt",
    "qgc-ArduPilotSITL-ArduRover.plan",
    "qgc-MissionPlanner.waypoints",
    "qgc-MissionPlanner.waypoints.txt",  # DO_JUMP repeat -1: a patrol, flown until stopped
    "qgc-OldFileFormat.mission",
    "qgc-SectionTest.plan",
    "qgc-simple_square.plan",
]

REFUSED = {
    "ap-AC_Avoidance-rover-fence-ac-avoid.txt": "a fence file (MAVProxy's lat/lon list",
    "ap-PolyFenceObjectAvoidanceAuto-rover-path-planning-fence.txt": "a fence file (QGC WPL 110",
    "ap-PolyFenceObjectAvoidanceBendyRulerEasierAuto-rover-path-bendyruler-fence.txt": (
        "a fence file (QGC WPL 110"
    ),
    "ap-Rally-rover-test-rally.txt": "rally points (RALLY lines)",
    "ap-GCSFailsafe-test_arming.txt": "item 2 (line 4) NAV_LOITER_UNLIM",
    "ap-Offboard-rover-guided-mission.txt": "item 3 NAV_GUIDED_ENABLE: it hands navigation",
}


@pytest.fixture(scope="module")
def wide(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("cfg") / "wide.yaml"
    path.write_text(yaml.safe_dump(WIDE))
    return path


def test_the_corpus_is_complete() -> None:
    """Every file kept is judged here, and every file judged is kept."""
    present = {p.name for p in GCS.iterdir()}
    assert present == set(FLOWN) | set(REFUSED) | {"README.md"}


@pytest.mark.parametrize("name", FLOWN)
def test_file_checks_with_its_commands(name: str, wide: Path) -> None:
    got = load_inputs(wide, GCS / name, ROLL)
    assert got.plan.waypoints
    if got.mission.has_commands():
        assert got.plan.program is not None and got.plan.program.steps


@pytest.mark.parametrize(("name", "words"), sorted(REFUSED.items()))
def test_file_is_refused_naming_why(name: str, words: str, wide: Path) -> None:
    path = GCS / name
    if not path.exists():
        pytest.fail(f"{name} missing from tests/data/gcs")
    with pytest.raises(InputsRefused) as err:
        load_inputs(wide, path, ROLL)
    assert any(words in p for p in err.value.problems), err.value.problems
    assert all(p.startswith(str(path)) for p in err.value.problems)


def test_what_rover_skips_is_listed_and_strict_refuses_it(wide: Path) -> None:
    got = load_inputs(wide, GCS / "qgc-simple_square.plan", ROLL)
    assert any("item 1 NAV_TAKEOFF: skipped, as ArduPilot Rover skips it" in n for n in got.notes)
    with pytest.raises(InputsRefused) as err:
        load_inputs(wide, GCS / "qgc-simple_square.plan", ROLL, strict=True)
    assert any("item 1 NAV_TAKEOFF" in p and "--strict" in p for p in err.value.problems)


def test_skip_unsupported_passes_over_the_offboard_handover(wide: Path) -> None:
    got = load_inputs(wide, GCS / "ap-Offboard-rover-guided-mission.txt", ROLL, True)
    assert any("item 3 NAV_GUIDED_ENABLE: passed over" in n for n in got.notes)


def test_a_fence_file_fences_the_mission_with_it(wide: Path) -> None:
    mission = GCS / "ap-PolyFenceObjectAvoidanceAuto-rover-path-planning-mission.txt"
    fence = GCS / "ap-PolyFenceObjectAvoidanceAuto-rover-path-planning-fence.txt"
    got = load_inputs(wide, mission, ROLL, fence=fence)
    assert len(got.mission.geofence_polygon) == 19  # its inclusion polygon keeps the rover in
    assert got.fence is not None
    assert sum(not p.inclusion for p in got.fence.polygons) == 1  # kept to plan around
    assert sum(not c.inclusion for c in got.fence.circles) == 1
    old = load_inputs(wide, mission, ROLL, fence=GCS / "ap-AC_Avoidance-rover-fence-ac-avoid.txt")
    assert len(old.mission.geofence_polygon) == 4  # return point dropped, closing vertex too
