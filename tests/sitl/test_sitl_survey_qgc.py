"""The survey block flown from QGroundControl's Start Mission, on real ArduPilot Rover SITL: as
precise as ``helixd run`` flying it (opt-in: ``HELIXD_SITL_BIN``).

Two flights of ``config/missions/survey.yaml`` (six 30 m transects 3 m apart, 195 m, ROLL at
0.6 m/s), each on a freshly booted SITL with helixd-guard, both measured the same way from the
autopilot's side (LOCAL_POSITION_NED on the observer link against the planned polyline):

* ``helixd run --mission survey.yaml`` (its 'start' frame: the pose at its first step);
* ``helixd serve`` with the same transects laid out from the rover's pose at rest, uploaded
  to the autopilot as QGroundControl's Plan view does (home + NAV_WAYPOINTs, lat/lon), and
  started with QGroundControl's Start Mission (``APMFirmwarePlugin::startMission``: GUIDED, a
  normal arm, MAV_CMD_MISSION_START to the autopilot) — the autopilot in AUTO, helixd driving
  with its own guidance, ArduPilot's WP_RADIUS not cutting its corners.

Asserted: the flight from the ground station is no less precise than ``helixd run`` (RMS and
largest cross-track error within a few centimetres of it). ``-s`` prints both rows.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from helixd.base.frames import MissionFrame, NedPose, latlon_to_ne
from helixd.recorder.track import TrackMetrics
from tests.sitl.conftest import SITL_BIN_ENV, SitlVehicle, pick_instance, sitl_speedup, start_sitl
from tests.sitl.test_sitl_qgc import CONFIG as QGC_CONFIG
from tests.sitl.test_sitl_serve import HOME_LATLON, serve_proc
from tests.sitl.test_sitl_survey import MISSION_SIM_S, fly_helixd, row, track_of
from tests.support import sitl_steps as crew
from tests.support.skid_setup import SURVEY_XY_M, metrics_in_frame

if TYPE_CHECKING:
    from tests.sitl.conftest import DaemonRun

pytestmark = [pytest.mark.sitl, pytest.mark.timeout(3000)]

MODE_GUIDED, MODE_AUTO = 15, 10
MAV_CMD_REQUEST_MESSAGE = 512
MSG_GPS_GLOBAL_ORIGIN = 49
# "no less precise": within what two flights of the same code differ by on this SITL
RMS_MARGIN_M = 0.02
MAX_MARGIN_M = 0.05


def fly_from_qgc(sitl: SitlVehicle, workdir: Path) -> TrackMetrics | None:
    """Upload the transects as the Plan view does, press Start Mission, wait for the end."""
    obs = sitl.obs
    assert obs.command_long(MAV_CMD_REQUEST_MESSAGE, (float(MSG_GPS_GLOBAL_ORIGIN),)) == 0
    origin = obs.wait_value(lambda: obs.latest.get("GPS_GLOBAL_ORIGIN"), 10.0, "GPS_GLOBAL_ORIGIN")
    # the ground station's waypoints are placed from SITL's home; LOCAL_POSITION_NED from the
    # EKF origin: the offset between the two, once
    home_n, home_e = latlon_to_ne(*HOME_LATLON, origin.latitude / 1e7, origin.longitude / 1e7)
    at_rest = obs.position()
    assert at_rest is not None
    yaw = obs.yaw_at(at_rest.t_boot_s)
    assert yaw is not None
    start = NedPose(at_rest.north_m, at_rest.east_m, yaw)
    frame = MissionFrame.start_at(start)
    points = [frame.to_ned(x, y) for x, y in SURVEY_XY_M]
    from_home = [(n - home_n, e - home_e) for n, e in points]

    gcs = crew.ground_station(sitl)
    d = serve_proc(workdir, sitl, QGC_CONFIG)
    try:
        crew.upload_when_asked(d, lambda: gcs.upload(from_home, 30.0))  # Plan view: Upload
        # Start Mission: APMFirmwarePlugin::startMission — Guided, arm, MISSION_START
        started = crew.start_mission(sitl, gcs, wait_armed=False)
        assert started == mavlink2.MAV_RESULT_ACCEPTED, started
        obs.wait_until(lambda: obs.mode() == MODE_AUTO, crew.STEP_WAIT_S, "AUTO")
        wait_s = crew.STATE_WAIT_S + MISSION_SIM_S / sitl.speedup
        d.wait_line("event=serve_state state=completed", wait_s)
    finally:
        crew.close_serve(d, gcs, workdir)
    runs = sorted(p for p in (workdir / "runs").iterdir() if p.is_dir())
    summaries = [json.loads((r / "summary.json").read_text()) for r in runs]
    assert [s["completed"] for s in summaries] == [True], summaries
    track = [p for p in track_of(sitl) if p.t_s >= at_rest.t_boot_s]
    return metrics_in_frame(track, SURVEY_XY_M, start)


def test_survey_from_qgroundcontrol_as_precise_as_helixd_run(
    sitl: SitlVehicle, launch_helixd: Callable[..., DaemonRun], tmp_path: Path
) -> None:
    by_run = fly_helixd(sitl, launch_helixd)
    print(row("helixd run", by_run))
    sitl.stop()

    workdir = tmp_path / "sitl-qgc"
    workdir.mkdir()
    binary = Path(os.environ[SITL_BIN_ENV]).resolve()
    qgc_sitl = start_sitl(binary, workdir, pick_instance(), sitl_speedup(), guard=True)
    t0 = time.monotonic()
    try:
        by_qgc = fly_from_qgc(qgc_sitl, workdir)
    finally:
        qgc_sitl.stop()
    print(row("helixd serve, QGroundControl's Start Mission (AUTO)", by_qgc))
    print(f"survey from QGC: {time.monotonic() - t0:.0f} s wall")

    assert by_run is not None and by_qgc is not None
    assert by_qgc.cross_track_rms_m <= by_run.cross_track_rms_m + RMS_MARGIN_M
    assert by_qgc.cross_track_max_m <= by_run.cross_track_max_m + MAX_MARGIN_M
    assert by_qgc.final_error_m <= by_run.final_error_m + MAX_MARGIN_M
