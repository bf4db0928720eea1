"""Missions with ArduPilot Rover's commands, flown by the real CLI against the simulator over
UDP and judged from the simulator's side: the speed on each leg against DO_CHANGE_SPEED, a
hold at a waypoint, a DO_JUMP loop flown twice, a DO_SET_SERVO seen by the autopilot at its
waypoint, NAV_RETURN_TO_LAUNCH ending at the autopilot's home — and ground-station files
written by ArduPilot's own test suite."""

from __future__ import annotations

import json
import math
import statistics
from pathlib import Path
from typing import Any

import pytest
import yaml

from helixd.base.exitcodes import ExitCode
from helixd.sim.snapshot import HistoryEntry
from tests.support.harness import (
    NEUTRAL_TOLERANCE_US,
    NEUTRAL_US,
    Trace,
    secured,
)
from tests.support.paths import DATA_DIR
from tests.support.simulated import SimulatedFlight, simulated_flight

pytestmark = pytest.mark.integration

RUN_DOWN_S = 1.0  # the motors' lag (and the last override in flight) after neutral
SERVO = 9  # a servo output that drives no scroll (SERVO9_FUNCTION 0)

# items, numbered as a ground station numbers them (1 = the first entry)
MISSION = {
    "name": "commands",
    "mode": "roll",
    "frame": "start",
    "waypoints": [
        {"x": 10, "y": 0},  # 1  leg at the cruise speed, 0.6 m/s
        {"command": "DO_CHANGE_SPEED", "speed_mps": 0.3},  # 2
        {"x": 10, "y": 8, "hold_s": 6},  # 3  at 0.3 m/s, then stopped 6 s
        {"command": "DO_SET_SERVO", "channel": SERVO, "pwm_us": 1900},  # 4 when 3 completes
        {"x": 2, "y": 8},  # 5  still 0.3 m/s
        {"command": "DO_CHANGE_SPEED", "speed_mps": 0.5},  # 6
        {"x": 2, "y": 2},  # 7  0.5 m/s
        {"x": 8, "y": 2},  # 8
        {"command": "DO_JUMP", "item": 7, "repeat": 1},  # 9  back to 7 once: 7, 8 twice
        {"command": "NAV_RETURN_TO_LAUNCH"},  # 10 to the autopilot's home
    ],
}
# (from, to, commanded speed): the legs as flown, the loop's twice
LEGS = [
    ((0, 0), (10, 0), 0.6),
    ((10, 0), (10, 8), 0.3),
    ((10, 8), (2, 8), 0.3),
    ((2, 8), (2, 2), 0.5),
    ((2, 2), (8, 2), 0.5),  # twice
    ((8, 2), (2, 2), 0.5),  # the leg after the jump
    ((8, 2), (0, 0), 0.5),  # the return home
]


def leg_speeds(trace: Trace, a: tuple[float, float], b: tuple[float, float]) -> list[float]:
    """The rover's true speed wherever it drove the leg a → b in that direction, away from
    its ends (1.5 m: where it accelerates and brakes) and within 0.3 m of the line."""
    (ax, ay), (bx, by) = a, b
    length = math.hypot(bx - ax, by - ay)
    ux, uy = (bx - ax) / length, (by - ay) / length
    out = []
    for _, s in trace.samples:
        x, y = s.north_m, -s.east_m  # start frame: rover at the origin facing north (yaw 0)
        along = (x - ax) * ux + (y - ay) * uy
        across = abs(-(x - ax) * uy + (y - ay) * ux)
        heading_x, heading_y = math.cos(s.yaw_ned_rad), -math.sin(s.yaw_ned_rad)
        forward = heading_x * ux + heading_y * uy > 0.9  # ROLL drives along its heading
        if 1.5 <= along <= length - 1.5 and across < 0.3 and forward:
            out.append(s.speed_mps)
    return out


def visits(trace: Trace, x: float, y: float, radius_m: float = 0.4) -> int:
    """How many times the rover came within ``radius_m`` of (x, y) (start frame)."""
    inside, count = False, 0
    for _, s in trace.samples:
        near = math.hypot(s.north_m - x, -s.east_m - y) < radius_m
        if near and not inside:
            count += 1
        inside = near
    return count


def neutral_intervals(outputs: list[HistoryEntry]) -> list[tuple[float, float]]:
    """(start, end) in simulated seconds of every stretch the four scroll outputs (1..4) all
    stood at neutral, from the simulator's own log of output changes (exact, whatever the
    test process saw of its snapshots). The log has one entry per channel; the entries of one
    simulated instant (one RC_CHANNELS_OVERRIDE sets all four) are judged together, as the
    plant meets them: a half-applied message is not a state the scrolls were ever in."""
    pwm = [0, 0, 0, 0]
    out: list[tuple[float, float]] = []
    since: float | None = None
    scroll = [e for e in outputs if int(str(e.details["channel"])) <= 4]
    for i, e in enumerate(scroll):
        pwm[int(str(e.details["channel"])) - 1] = int(str(e.details["pwm_us"]))
        if i + 1 < len(scroll) and scroll[i + 1].sim_time_s == e.sim_time_s:
            continue  # the rest of this instant's channels first
        neutral = all(abs(p - NEUTRAL_US) <= NEUTRAL_TOLERANCE_US for p in pwm)
        if neutral and since is None:
            since = e.sim_time_s
        elif not neutral and since is not None:
            out.append((since, e.sim_time_s))
            since = None
    return out


def test_speed_changes_hold_jump_servo_and_return_home(tmp_path: Path) -> None:
    path = tmp_path / "commands.yaml"
    path.write_text(yaml.safe_dump(MISSION))
    flown = simulated_flight(tmp_path, path, terrain="hard", noise="none", initial_yaw_ned_rad=0.0)
    code, log, run_dir, snap, trace = (
        flown.code,
        flown.log,
        flown.run_dir(),
        flown.snapshot,
        flown.trace,
    )
    servo_sets = flown.server.history.entries("servo_set")
    outputs = flown.server.history.entries("output")
    assert code == ExitCode.OK, log[-3000:]
    assert secured(snap)

    # each leg at its commanded speed (median of the rover's true speed, 10 %)
    for a, b, commanded in LEGS:
        speeds = leg_speeds(trace, a, b)
        assert len(speeds) > 20, (a, b)
        measured = statistics.median(speeds)
        print(f"leg {a} → {b}: {measured:.3f} m/s measured, {commanded} commanded")
        assert measured == pytest.approx(commanded, rel=0.10), (a, b)

    # stopped at item 3 for its 6 s, not faulted (the run completed: exit 0): the scrolls at
    # neutral for the 6 s (the simulator's own output log), the rover standing still (not
    # rolling, not turning) in every snapshot of it after the motors ran down, at (10, 8)
    at_wp3 = [
        s.sim_time_s
        for _, s in trace.samples
        if math.hypot(s.north_m - 10, -s.east_m - 8) < 0.3 and s.speed_mps < 0.02
    ]
    # A stop is a neutral stretch longer than the motors' run-down; a command passing through
    # the ±NEUTRAL_TOLERANCE_US band is not one (a leg starting from rest at the acceleration
    # limit spends a step or a few there: 0.04 m/s differential is ±6 µs). The hold is one
    # stretch, the only stop at (10, 8): a hold broken in two shows as two, or as one too short
    (start, end), *others = [
        (a, b)
        for a, b in neutral_intervals(outputs)
        if b - a > RUN_DOWN_S and any(a <= t <= b for t in at_wp3)
    ]
    assert not others
    inside = [s for _, s in trace.samples if start + RUN_DOWN_S <= s.sim_time_s <= end]
    still = all(s.speed_mps < 0.02 and abs(s.wz_body_radps) < 0.02 for s in inside)
    where = max(math.hypot(s.north_m - 10, -s.east_m - 8) for s in inside)
    print(
        f"hold at (10, 8): scrolls neutral {end - start:.2f} s of autopilot time (6 s asked); "
        f"rover still in all {len(inside)} snapshots after {RUN_DOWN_S} s, within {where:.3f} m"
    )
    assert 6.0 <= end - start <= 6.5
    assert still and len(inside) > 10 and where < 0.2

    # the DO_JUMP loop flown twice: (2, 2) and (8, 2) each reached twice
    assert visits(trace, 2, 2) == 2 and visits(trace, 8, 2) == 2

    # the servo command the autopilot got, once per pass over item 4: at waypoint 3 (10, 8)
    (entry,) = [e for e in servo_sets if e.details["channel"] == SERVO]
    assert entry.details["pwm_us"] == 1900
    at = min(trace.samples, key=lambda ts: abs(ts[1].sim_time_s - entry.sim_time_s))[1]
    print(f"DO_SET_SERVO {SERVO} seen at ({at.north_m:.2f}, {-at.east_m:.2f}) (waypoint (10, 8))")
    assert math.hypot(at.north_m - 10, -at.east_m - 8) < 0.5
    assert snap.outputs_us[SERVO - 1] == 1900  # latched, as ArduPilot keeps it

    # NAV_RETURN_TO_LAUNCH ended at the autopilot's home
    assert snap.home_ne_m is not None
    end = math.hypot(snap.north_m - snap.home_ne_m[0], snap.east_m - snap.home_ne_m[1])
    print(f"RTL ended {end:.3f} m from home")
    assert end < 0.3

    # the run's record: every payload command sent with its answer, the steps in order
    events = [json.loads(ln) for ln in (run_dir / "events.jsonl").read_text().splitlines()]
    sent = [e for e in events if e["event"] == "mission_command"]
    assert [(e["item"], e["command"], e["accepted"]) for e in sent] == [(4, "DO_SET_SERVO", True)]
    started = [e["item"] for e in events if e.get("kind") == "step_started"]
    assert started == [1, 3, 5, 7, 8, 7, 8, 10]
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["completed"] and summary["waypoints_total"] == 8


SIM_HOME_AUTOTEST = (40.071377, -105.229790)  # row 0 (home) of ArduPilot's autotest missions


def autotest_flight(
    tmp_path: Path, name: str, config: dict[str, Any], **sim: Any
) -> SimulatedFlight:
    """ArduPilot's autotest mission ``name`` (tests/data/gcs) on hard ground, low noise, seed 2,
    with the simulator's origin at the file's home; ``sim``: more simulator settings."""
    lat_deg, lon_deg = SIM_HOME_AUTOTEST
    mission = DATA_DIR / "gcs" / name
    return simulated_flight(
        tmp_path, mission, config, terrain="hard", noise="low", seed=2,
        origin_lat_deg=lat_deg, origin_lon_deg=lon_deg, **sim,
    )  # fmt: skip


def test_ardupilots_own_rtl_mission_flies_and_returns_home(tmp_path: Path) -> None:
    """ArduPilot's autotest DriveRTL mission (two waypoints, then NAV_RETURN_TO_LAUNCH with
    lat/lon 0, 0), with the simulator's origin at the file's home."""
    cfg = {
        "mission": {"ground_station_mode": "roll"},
        "safety": {"geofence_radius_m": 200.0},
    }
    flown = autotest_flight(tmp_path, "ap-DriveRTL-rtl.txt", cfg)
    code, log, snap = flown.code, flown.log, flown.snapshot
    assert code == ExitCode.OK, log[-3000:]
    assert snap.home_ne_m is not None
    end = math.hypot(snap.north_m - snap.home_ne_m[0], snap.east_m - snap.home_ne_m[1])
    assert end < 0.5


def test_ardupilots_camera_mission_triggers_the_camera_by_distance(tmp_path: Path) -> None:
    """ArduPilot's CameraMission: DO_SET_CAM_TRIGG_DIST 2 m, then 5 m; the simulator's camera
    (CAM1_TYPE 1) takes the pictures as AP_Camera does, and helixd sent the commands at their
    places."""
    cfg = {
        "mission": {"ground_station_mode": "roll", "max_range_m": 1000.0},
        "safety": {"geofence_radius_m": 300.0},
    }
    mission = "ap-CameraMission-rover-camera-mission.txt"
    flown = autotest_flight(tmp_path, mission, cfg, params={"CAM1_TYPE": 1})
    code, log, run_dir, snap = flown.code, flown.log, flown.run_dir(), flown.snapshot
    assert code == ExitCode.OK, log[-3000:]
    events = [json.loads(ln) for ln in (run_dir / "events.jsonl").read_text().splitlines()]
    sent = [(e["item"], e["params"][0]) for e in events if e["event"] == "mission_command"]
    assert sent == [(1, 2.0), (3, 5.0)]
    # 65 m at 2 m, then about 100 m at 5 m: the camera's own count
    print(f"pictures taken: {snap.pictures}")
    assert 45 <= snap.pictures <= 60


def test_a_servo_command_on_a_scroll_passthrough_is_refused_before_arming(tmp_path: Path) -> None:
    """Output 5 passes RC1 through (SERVO5_FUNCTION 51), and RC1 drives scroll 1: `check`
    cannot know the autopilot's functions, preflight reads them and refuses (exit 3, nothing
    armed), naming item, output and function; the servo is never touched."""
    path = tmp_path / "servo.yaml"
    mission = {
        "name": "servo",
        "mode": "roll",
        "frame": "start",
        "waypoints": [
            {"x": 3, "y": 0},
            {"command": "DO_SET_SERVO", "channel": 5, "pwm_us": 1900},
            {"x": 6, "y": 0},
        ],
    }
    path.write_text(yaml.safe_dump(mission))
    flown = simulated_flight(tmp_path, path, params={"SERVO5_FUNCTION": 51})
    code, log, snap = flown.code, flown.log, flown.snapshot
    servo_sets = flown.server.history.entries("servo_set")
    assert code == ExitCode.PREFLIGHT, log[-3000:]
    assert "item 2 DO_SET_SERVO: output 5 passes RC1 through (SERVO5_FUNCTION = 51)" in log
    assert not snap.armed and servo_sets == []
