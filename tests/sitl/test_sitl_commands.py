"""A mission with commands on real ArduPilot Rover SITL (opt-in: ``HELIXD_SITL_BIN``): written
in helixd's YAML, uploaded to ArduPilot with ``helixd mission upload``, downloaded and flown by
``helixd run --mission autopilot``, judged from ArduPilot's side (a second link).

The mission: 12 m north at the cruise speed (0.6 m/s), DO_CHANGE_SPEED 0.3, 8 m east at
0.3 m/s, DO_SET_SERVO output 9 → 1900 µs (a function-0 output: no scroll, no pilot switch),
back 8 m south, NAV_RETURN_TO_LAUNCH. Checked: exit 0; LOCAL_POSITION_NED speed on each leg
within 10 % of its commanded speed; SERVO_OUTPUT_RAW output 9 at 1900 first seen at waypoint 2;
the rover back at ArduPilot's home (HOME_POSITION) at the end.
"""

from __future__ import annotations

import itertools
import json
import math
import statistics
import subprocess
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import pytest
import yaml

from helixd.base.exitcodes import ExitCode
from helixd.base.frames import ne_to_latlon
from tests.support.cli import helixd_process as helixd
from tests.support.skid_setup import helixd_sitl_config

if TYPE_CHECKING:
    from tests.sitl.conftest import PositionSample, SitlVehicle

pytestmark = [pytest.mark.sitl, pytest.mark.timeout(1200)]

HOME_LATLON = (-35.363261, 149.165230)  # conftest.HOME: SITL's home, where the rover starts
SERVO_OUTPUT = 9
SERVO_PWM = 1900
# (north, east) of the places, from home, and the speed of the leg to each
PLACES = [((12.0, 0.0), 0.6), ((12.0, 8.0), 0.3), ((4.0, 8.0), 0.3), ((0.0, 0.0), 0.3)]
WALL_TIMEOUT_S = 900.0


def mission_yaml() -> dict[str, object]:
    def place(n: float, e: float) -> dict[str, float]:
        lat, lon = ne_to_latlon(n, e, *HOME_LATLON)
        return {"lat": lat, "lon": lon}

    return {
        "name": "sitl-commands",
        "mode": "roll",
        "frame": "global",
        "waypoints": [
            place(12.0, 0.0),
            {"command": "DO_CHANGE_SPEED", "speed_type": 1, "speed_mps": 0.3},
            place(12.0, 8.0),
            {"command": "DO_SET_SERVO", "channel": SERVO_OUTPUT, "pwm_us": SERVO_PWM},
            place(4.0, 8.0),
            {"command": "NAV_RETURN_TO_LAUNCH"},
        ],
    }


def leg_speeds(
    track: list[PositionSample], a: tuple[float, float], b: tuple[float, float]
) -> list[float]:
    """Speeds (from successive LOCAL_POSITION_NED) on the leg a → b, away from its ends."""
    length = math.dist(a, b)
    un, ue = (b[0] - a[0]) / length, (b[1] - a[1]) / length
    out = []
    for p, q in itertools.pairwise(track):
        dt = q.t_boot_s - p.t_boot_s
        if dt <= 0:
            continue
        along = (q.north_m - a[0]) * un + (q.east_m - a[1]) * ue
        across = abs(-(q.north_m - a[0]) * ue + (q.east_m - a[1]) * un)
        if 2.0 <= along <= length - 2.0 and across < 0.5:
            out.append(math.hypot(q.north_m - p.north_m, q.east_m - p.east_m) / dt)
    return out


def test_autopilot_mission_with_speed_change_and_servo(sitl: SitlVehicle, tmp_path: Path) -> None:
    cfg = tmp_path / "helixd.yaml"
    cfg.write_text(yaml.safe_dump(helixd_sitl_config("rc_override", sitl.helixd_url)))
    src = tmp_path / "commands.yaml"
    src.write_text(yaml.safe_dump(mission_yaml(), sort_keys=False))
    url = sitl.helixd_url

    up = helixd(["mission", "upload", str(src), "--connect", url, "-c", str(cfg)], tmp_path, 120)
    assert up.returncode == 0, up.stderr[-3000:]
    print(up.stdout.strip())

    seen: dict[str, tuple[float, float]] = {}

    def servo_at_pwm() -> bool:
        msg = sitl.obs.latest.get("SERVO_OUTPUT_RAW")
        pos = sitl.obs.position()
        if msg is None or pos is None:
            return False
        if int(getattr(msg, f"servo{SERVO_OUTPUT}_raw")) == SERVO_PWM and "servo" not in seen:
            seen["servo"] = (pos.north_m, pos.east_m)
        return "servo" in seen

    home_ne = sitl.start_ne_m
    run = subprocess.Popen(
        [sys.executable, "-m", "helixd", "run", "--mission", "autopilot", "--mode", "roll",
         "--connect", url, "-c", str(cfg), "--run-dir", str(tmp_path / "runs")],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        sitl.obs.wait_until(servo_at_pwm, WALL_TIMEOUT_S, "output 9 at 1900 µs")
        _, err = run.communicate(timeout=WALL_TIMEOUT_S)
    finally:
        if run.poll() is None:
            run.kill()
            run.communicate()
    assert run.returncode == ExitCode.OK, err[-4000:]
    assert "mission : autopilot at" in err and "6 mission items" in err

    # speed on each leg, from ArduPilot's LOCAL_POSITION_NED
    track = [p for p in sitl.obs.positions if p.t_boot_s >= sitl.start_t_boot_s]
    previous = home_ne
    for (n, e), commanded in PLACES:
        target = (home_ne[0] + n, home_ne[1] + e)
        speeds = leg_speeds(track, previous, target)
        assert len(speeds) >= 10, (previous, target)
        measured = statistics.median(speeds)
        print(f"leg {previous} → {target}: {measured:.3f} m/s measured, {commanded} commanded")
        assert measured == pytest.approx(commanded, rel=0.10)
        previous = target

    # the servo command at its place: when waypoint 2 (12 m N, 8 m E) was reached
    servo_n, servo_e = seen["servo"]
    off = math.dist((servo_n, servo_e), (home_ne[0] + 12.0, home_ne[1] + 8.0))
    print(f"output {SERVO_OUTPUT} at {SERVO_PWM} µs first seen {off:.2f} m from waypoint 2")
    assert off < 1.0

    # back home: ArduPilot's own HOME_POSITION, from the run's record
    end = sitl.obs.position()
    assert end is not None
    home_end = math.dist((end.north_m, end.east_m), home_ne)
    print(f"NAV_RETURN_TO_LAUNCH ended {home_end:.2f} m from home")
    assert home_end < 1.0
    run_dir = next((tmp_path / "runs").iterdir())
    events = [json.loads(ln) for ln in (run_dir / "events.jsonl").read_text().splitlines()]
    sent = [e for e in events if e["event"] == "mission_command"]
    assert [(e["item"], e["command"], e["accepted"]) for e in sent] == [(4, "DO_SET_SERVO", True)]
    home = next(e for e in events if e["event"] == "home_position")
    assert math.dist((home["north_m"], home["east_m"]), home_ne) < 1.0
