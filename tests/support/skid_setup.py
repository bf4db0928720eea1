"""helixd's configuration for ArduPilot's skid-steer rover (real SITL ``--model rover-skid``, and
the built-in simulator's ``sitl_skid`` plant written from the same SIM_Rover.cpp).

A plain module (no fixtures), so that ``tests/integration/test_skid_plant.py`` flies the very
configuration the opt-in SITL suite flies. See ``conftest.py``'s docstring and ``README.md`` for
why scroll 1 → output 3 and scroll 3 (reversed) → output 1.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from helixd.base.frames import MissionFrame, NedPose
from helixd.control.kinematics import rpm_to_radps
from helixd.mission.shapes import survey_block
from helixd.recorder.track import (
    TrackMetrics,
    TrackPoint,
    mission_window,
    planned_polyline_ned,
    track_metrics,
)

HELIXD_SYSID = 247  # link.source_system's default; helix-skid.parm sets MAV_GCS_SYSID to it

# The skid model as a Helix: scroll → (output channel, reversed).
SKID_CHANNELS: tuple[tuple[int, bool], ...] = ((3, False), (4, False), (1, True), (2, True))
# SIM_Rover.cpp skid constants: full command ±1 → 4 m/s; (m1 − m2) = 1 → 140 °/s.
SKID_MAX_SPEED_MPS = 4.0
SKID_TURN_RATE_DPS = 140.0
MAX_RPM = 195.0

# The ROLL-mode 10 m square (config/missions/square.yaml): x forward, y left of the start pose.
SQUARE_XY_M: tuple[tuple[float, float], ...] = ((10.0, 0.0), (10.0, 10.0), (0.0, 10.0), (0.0, 0.0))
# The survey block (config/missions/survey.yaml): six 30 m transects 3 m apart.
SURVEY_XY_M: tuple[tuple[float, float], ...] = tuple(survey_block())
REST_TOLERANCE_M = 0.05  # observer: "not yet left the start" / "come to rest"


def skid_vehicle_geometry(max_rpm: float = MAX_RPM) -> dict[str, float]:
    """Helix geometry for which eq. 2 *is* the skid model, so helixd's thesis gains see the
    plant they were tuned for: v = r·ω_max·f → r = 4 m/s / ω_max; yaw = 2k·wz/(r·ω_max) ·
    140 °/s → k = l_x + l_y = 4 m/s / (2 · 140 °/s)."""
    radius_m = SKID_MAX_SPEED_MPS / rpm_to_radps(max_rpm)
    k_m = SKID_MAX_SPEED_MPS / (2.0 * math.radians(SKID_TURN_RATE_DPS))
    return {"scroll_radius_m": radius_m, "lx_m": k_m / 2.0, "ly_m": k_m / 2.0, "max_rpm": max_rpm}


def skid_actuation(backend: str, channel_offset: int = 0) -> dict[str, Any]:
    """HelixdConfig ``actuation`` for the skid mapping (on RC channels shifted by
    ``channel_offset``: 8 drives outputs whose functions are RCIN9..12)."""
    return {
        "backend": backend,
        "channels": [
            {
                "channel": channel + channel_offset,
                "reversed": rev,
                "pwm_min_us": 1000,
                "pwm_max_us": 2000,
            }
            for channel, rev in SKID_CHANNELS
        ],
    }


# Corner arcs: the suite flies them with this budget (m), the value they were
# measured with against AUTO and the default (set explicitly, so the suite keeps it).
ARC_BUDGET_M = 0.25


def helixd_sitl_config(backend: str, url: str, channel_offset: int = 0) -> dict[str, Any]:
    """The helixd.yaml the suite flies with (HelixdConfig fields; everything else default)."""
    return {
        "vehicle": skid_vehicle_geometry(),
        "control": {"corner_error_m": ARC_BUDGET_M},
        "link": {
            "url": url,
            "source_system": HELIXD_SYSID,
            # 5 Hz keeps FS_GCS_TIMEOUT (5 s, simulated) safe up to --speedup 10.
            "heartbeat_rate_hz": 5.0,
        },
        "actuation": skid_actuation(backend, channel_offset),
        "startup": {
            # a normal arm, every PreArm check made: helix-skid.parm's SERVO16_FUNCTION 94
            # (Script1) passes ArduPilot's motor-output check; the daemon retries while the
            # EKF/home checks still refuse after boot
            "connect_timeout_s": 60.0,
            "arm_timeout_s": 60.0,
            "arm_retry_interval_s": 1.0,
        },
    }


def first_step_t_s(run_dir: Path) -> float:
    """Autopilot time of helixd's first control step (flight.csv's first row): where its
    'start' frame was taken."""
    rows = (run_dir / "flight.csv").read_text(encoding="utf-8").splitlines()
    return float(next(r for r in rows if r and r[0].isdigit()).split(",", 1)[0])


def helixd_start_frame(run_dir: Path) -> tuple[NedPose, float]:
    """(pose, autopilot time) of helixd's first control step — its 'start' frame — from the
    run's flight.csv (north_m, east_m, yaw_ned_rad of the pose it steered by)."""
    lines = (run_dir / "flight.csv").read_text(encoding="utf-8").splitlines()
    rows = [ln.split(",") for ln in lines if ln and not ln.startswith("#")]
    col = {name: i for i, name in enumerate(rows[0])}
    first = rows[1]
    pose = NedPose(
        float(first[col["north_m"]]), float(first[col["east_m"]]), float(first[col["yaw_ned_rad"]])
    )
    return pose, float(first[col["t_boot_s"]])


def metrics_in_frame(
    track: Sequence[TrackPoint], waypoints_xy_m: Sequence[tuple[float, float]], start: NedPose
) -> TrackMetrics | None:
    """Observer metrics of ``track`` against the plan laid out in the 'start' frame at
    ``start`` (e.g. the frame helixd flew in, :func:`helixd_start_frame`)."""
    frame = MissionFrame.start_at(start)
    polyline = planned_polyline_ned(waypoints_xy_m, frame, (start.north_m, start.east_m))
    return track_metrics(track, polyline, REST_TOLERANCE_M)


def mission_metrics(
    track: Sequence[TrackPoint],
    yaw_at: Callable[[float], float | None],
    waypoints_xy_m: Sequence[tuple[float, float]],
    start_t_s: float | None = None,
) -> TrackMetrics | None:
    """Observer metrics of a ``start``-frame mission (helixd.recorder.track): the planned
    polyline starts at the last position still at rest, heading as ATTITUDE reported it then
    (helixd's 'start' frame). With ``start_t_s`` (the autopilot time the mission's frame was
    taken, e.g. helixd's first control step) the frame is the observer's position and ATTITUDE
    at that time instead: on 30 m legs a 0.25° drift of the EKF's yaw between that moment
    and the rover's departure moves the far end of the plan by 0.13 m."""
    if len(track) < 2:
        return None
    first, _ = mission_window(track, REST_TOLERANCE_M)
    if start_t_s is not None:
        first = min(range(len(track)), key=lambda i: abs(track[i].t_s - start_t_s))
    start = track[first]
    yaw = yaw_at(start.t_s)
    if yaw is None:
        return None
    frame = MissionFrame.start_at(NedPose(start.north_m, start.east_m, yaw))
    polyline = planned_polyline_ned(waypoints_xy_m, frame, (start.north_m, start.east_m))
    return track_metrics(track, polyline, REST_TOLERANCE_M)


def square_metrics(
    track: Sequence[TrackPoint],
    yaw_at: Callable[[float], float | None],
    start_t_s: float | None = None,
) -> TrackMetrics | None:
    """:func:`mission_metrics` of the square."""
    return mission_metrics(track, yaw_at, SQUARE_XY_M, start_t_s)
