"""`run` applies the shared validation in preflight, with the start pose, before arming.

A ``local_ned`` mission whose geofence radius can only be checked once the start pose is
known: ``check`` passes it (and says what is left for preflight); ``run`` against the real
simulator over UDP refuses it in preflight (exit 3) and, seen from the autopilot, never arms
and never overrides a channel.
"""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from helixd.base.exitcodes import ExitCode
from helixd.cli.app import app
from tests.support.simulated import simulated_flight

MISSION = "name: far\nmode: omni\nframe: local_ned\nwaypoints:\n  - {north: 60, east: 0}\n"


def test_check_leaves_the_radius_to_preflight(tmp_path: Path) -> None:
    path = tmp_path / "far.yaml"
    path.write_text(MISSION, encoding="utf-8")
    result = CliRunner().invoke(app, ["check", "--mission", str(path)])
    assert result.exit_code == 0, result.output
    assert "preflight: run checks with the start pose: geofence radius" in result.output


def test_run_refuses_in_preflight_before_arming(tmp_path: Path) -> None:
    path = tmp_path / "far.yaml"
    path.write_text(MISSION, encoding="utf-8")
    # The rover starts 60 m south of the EKF origin: the waypoint is 120 m away (fence 100 m).
    flown = simulated_flight(tmp_path, path, initial_north_m=-60.0)
    code, log, snap = flown.code, flown.log, flown.snapshot
    assert code == ExitCode.PREFLIGHT, log
    assert "waypoint 1 (waypoints[0]): 120.0 m from the start point" in log, log
    assert "safety.geofence_radius_m = 100.0 m" in log
    # the arm phase never started, and the autopilot is disarmed with no override active
    assert "phase=arm" not in log and "phase=preflight" in log, log
    assert not snap.armed
    assert not any(snap.overrides_active)
