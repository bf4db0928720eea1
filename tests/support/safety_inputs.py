"""A healthy snapshot of the safety monitor's inputs, 60 s into a mission (one place for the
watchdog tests and the tests that run the monitor beside another part)."""

from __future__ import annotations

from helixd.safety.watchdogs import SafetyInputs

HEALTHY = SafetyInputs(
    now_s=100.0,
    last_heartbeat_s=99.5,
    pose_rx_s=99.98,
    ekf_healthy=True,
    ekf_detail="",
    mode="MANUAL",
    expected_mode="MANUAL",
    armed=True,
    rc_inputs_us=(1500,) * 8,
    north_m=5.0,
    east_m=5.0,
    start_north_m=0.0,
    start_east_m=0.0,
    mission_elapsed_s=60.0,
    commanded_speed_mps=0.5,
    measured_speed_mps=0.45,
)
