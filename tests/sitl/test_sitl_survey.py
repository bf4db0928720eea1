"""The survey block on real ArduPilot Rover SITL: helixd against ArduPilot's own AUTO.

Both fly ``config/missions/survey.yaml`` (six 30 m transects 3 m apart joined by 3 m
crossovers, 195 m) at 0.6 m/s on the rover-skid model, each on a freshly booted SITL, and both
are measured the same way from the autopilot's side (LOCAL_POSITION_NED on the observer link
against the planned polyline, :func:`tests.support.skid_setup.mission_metrics`):

* helixd: ``helixd run --mission survey.yaml`` with the suite's configuration (RC override);
* AUTO: the same waypoints converted to lat/lon through the EKF origin and uploaded with
  ``helixd mission upload`` (a QGC WPL 110 file), outputs 1/3 given back to ArduPilot's skid
  mixer (functions 73/74 and the steering/throttle settings of ArduPilot's own
  rover-skid.parm), ``WP_SPEED`` 0.6 m/s and ``WP_RADIUS`` 1.0 m (the settings of the AUTO
  square in docs/measurements.md), armed and switched to AUTO by the observer.

Asserted: helixd is no slower than AUTO and its largest cross-track error is at
most half of AUTO's. ``-s`` prints both rows.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.base.frames import MissionFrame, NedPose, ne_to_latlon
from helixd.recorder.track import TrackMetrics, TrackPoint
from tests.sitl.conftest import SITL_BIN_ENV, SitlVehicle, pick_instance, sitl_speedup, start_sitl
from tests.support.paths import REPO_ROOT
from tests.support.skid_setup import SURVEY_XY_M, first_step_t_s, mission_metrics

if TYPE_CHECKING:
    from tests.sitl.conftest import DaemonRun, MavClient

pytestmark = [pytest.mark.sitl, pytest.mark.timeout(3000)]

SURVEY_MISSION = REPO_ROOT / "config" / "missions" / "survey.yaml"
SETUP_WALL_S = 180.0  # helixd connect → preflight → arm on a freshly booted SITL
MISSION_SIM_S = 600.0  # the block takes ~340–420 s of simulated time at 0.6 m/s
UPLOAD_TIMEOUT_S = 60.0
AT_REST_S = 3.0  # simulated seconds without moving that count as "stopped" after the last item
AT_REST_M = 0.02

MAV_CMD_COMPONENT_ARM_DISARM = 400
MAV_CMD_REQUEST_MESSAGE = 512
MSG_GPS_GLOBAL_ORIGIN = 49
ARM_WAIT_S = 60.0
NORMAL_ARM = 0.0  # param2: every PreArm check made (helix-skid.parm's Script1 output)
MODE_AUTO = 10
MAV_RESULT_ACCEPTED = 0
# ArduPilot's Tools/autotest/default_params/rover-skid.parm, plus the AUTO square's settings.
AUTO_PARAMS = {
    "SERVO1_FUNCTION": 73.0,  # ThrottleLeft: the skid mixer drives the model's left motor
    "SERVO3_FUNCTION": 74.0,  # ThrottleRight
    "ATC_STR_RAT_FF": 0.2,
    "CRUISE_SPEED": 3.0,
    "CRUISE_THROTTLE": 75.0,
    "WP_SPEED": 0.6,  # helixd's cruise speed (control.max_speed_mps)
    "WP_RADIUS": 1.0,  # the thesis's waypoint tolerance, as in docs/measurements.md
    "FS_GCS_ENABLE": 0.0,  # nobody sends GCS heartbeats while AUTO flies
}


def track_of(sitl: SitlVehicle) -> list[TrackPoint]:
    return [
        TrackPoint(p.t_boot_s, p.north_m, p.east_m)
        for p in sitl.obs.positions_since(sitl.start_t_boot_s)
    ]


def row(who: str, m: TrackMetrics | None) -> str:
    return f"survey block, {who}: {'no metrics' if m is None else m.line()}"


def wpl_text(points_latlon: list[tuple[float, float]], home: tuple[float, float]) -> str:
    """QGC WPL 110: row 0 home, then one NAV_WAYPOINT (16) per point, relative altitude 0."""
    lines = ["QGC WPL 110", f"0\t1\t0\t16\t0\t0\t0\t0\t{home[0]:.8f}\t{home[1]:.8f}\t0\t1"]
    for i, (lat, lon) in enumerate(points_latlon, 1):
        lines.append(f"{i}\t0\t3\t16\t0\t0\t0\t0\t{lat:.8f}\t{lon:.8f}\t0\t1")
    return "\n".join(lines) + "\n"


def fly_helixd(sitl: SitlVehicle, launch: Callable[..., DaemonRun]) -> TrackMetrics | None:
    daemon = launch("rc_override", SURVEY_MISSION)
    code = daemon.wait_exit(SETUP_WALL_S + MISSION_SIM_S / sitl.speedup)
    assert code == ExitCode.OK, daemon.log_text()[-4000:]
    # helixd's start frame is the pose at its first control step (flight.csv's first row)
    return mission_metrics(
        track_of(sitl), sitl.obs.yaw_at, SURVEY_XY_M, first_step_t_s(daemon.run_dir())
    )


def arm_normally(obs: MavClient) -> None:
    """Arm as a ground station does, every PreArm check made; retried while ArduPilot still
    refuses after boot (EKF, home), never forced."""
    deadline = time.monotonic() + ARM_WAIT_S
    while obs.command_long(MAV_CMD_COMPONENT_ARM_DISARM, (1.0, NORMAL_ARM)) != MAV_RESULT_ACCEPTED:
        assert time.monotonic() < deadline, "ArduPilot refused a normal arm for ARM_WAIT_S"
        time.sleep(1.0)


def fly_auto(sitl: SitlVehicle, workdir: Path) -> TrackMetrics | None:
    obs = sitl.obs
    for name, value in AUTO_PARAMS.items():
        obs.set_param(name, value)
    assert obs.command_long(MAV_CMD_REQUEST_MESSAGE, (float(MSG_GPS_GLOBAL_ORIGIN),)) == 0
    origin = obs.wait_value(lambda: obs.latest.get("GPS_GLOBAL_ORIGIN"), 10.0, "GPS_GLOBAL_ORIGIN")
    olat, olon = origin.latitude / 1e7, origin.longitude / 1e7
    start = obs.position()
    assert start is not None
    yaw = obs.yaw_at(start.t_boot_s)
    assert yaw is not None
    frame = MissionFrame.start_at(NedPose(start.north_m, start.east_m, yaw))
    points = [ne_to_latlon(*frame.to_ned(x, y), olat, olon) for x, y in SURVEY_XY_M]
    path = workdir / "survey-auto.waypoints"
    path.write_text(wpl_text(points, (olat, olon)), encoding="utf-8")
    env = dict(os.environ, PYTHONPATH=str(REPO_ROOT))
    upload = subprocess.run(
        [sys.executable, "-m", "helixd", "mission", "upload", str(path), "--connect",
         sitl.helixd_url],
        cwd=workdir, env=env, capture_output=True, text=True, timeout=UPLOAD_TIMEOUT_S,
    )  # fmt: skip
    assert upload.returncode == 0, upload.stdout + upload.stderr
    arm_normally(obs)
    assert obs.set_mode(MODE_AUTO) == MAV_RESULT_ACCEPTED
    last_seq = len(SURVEY_XY_M)

    def finished() -> bool:
        reached = obs.latest.get("MISSION_ITEM_REACHED")
        if reached is None or int(reached.seq) < last_seq:
            return False
        now = obs.position()
        if now is None:
            return False
        recent = obs.positions_since(now.t_boot_s - AT_REST_S)
        span = now.t_boot_s - recent[0].t_boot_s
        moved = max(abs(p.north_m - now.north_m) + abs(p.east_m - now.east_m) for p in recent)
        return span >= AT_REST_S - 0.5 and moved <= AT_REST_M

    obs.wait_until(
        finished, MISSION_SIM_S / sitl.speedup + 60.0, "AUTO: last item reached, at rest",
        abort=sitl.dead,
    )  # fmt: skip
    return mission_metrics(track_of(sitl), obs.yaw_at, SURVEY_XY_M, start.t_boot_s)


def test_survey_block_helixd_against_auto(
    sitl: SitlVehicle, launch_helixd: Callable[..., DaemonRun], tmp_path: Path
) -> None:
    helixd = fly_helixd(sitl, launch_helixd)
    print(row("helixd (line guidance, corner arcs)", helixd))
    sitl.stop()  # the AUTO flight gets a SITL of its own, booted the same way

    workdir = tmp_path / "sitl-auto"
    workdir.mkdir()
    binary = Path(os.environ[SITL_BIN_ENV]).resolve()
    # ArduPilot flies this one on its own: no helixd-guard, which would stop a rover whose
    # helixd is silent ("helixd-guard: no heartbeat yet, trim + HOLD")
    auto_sitl = start_sitl(binary, workdir, pick_instance(), sitl_speedup(), guard=False)
    try:
        auto = fly_auto(auto_sitl, workdir)
    finally:
        auto_sitl.stop()
    print(row("ArduPilot AUTO (WP_SPEED 0.6, WP_RADIUS 1.0)", auto))

    assert helixd is not None and auto is not None
    assert helixd.elapsed_s <= auto.elapsed_s
    assert helixd.cross_track_max_m <= 0.5 * auto.cross_track_max_m
    assert helixd.final_error_m <= auto.final_error_m + 0.05
