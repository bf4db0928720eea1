"""The few safety numbers the link needs, and nothing else of the safety configuration.

The link does not decide anything about the rover's safety; it needs four numbers to keep its
view of the autopilot honest: when HEARTBEAT silence means the link is lost, when an EKF
variance means unhealthy, how old a yaw may be to form a pose, and the bounds beyond which a
telemetry value is absurd. :func:`link_limits` takes them from
:class:`helixd.config.safety.SafetyConfig`, and the rest of the link sees only
:class:`LinkLimits`.
"""

from __future__ import annotations

from dataclasses import dataclass

from helixd.config.safety import SafetyConfig
from helixd.link.vehicle import TelemetryBounds


@dataclass(frozen=True, slots=True)
class LinkLimits:
    heartbeat_timeout_s: float  # autopilot HEARTBEAT silence that marks the link lost
    ekf_variance_max: float  # EKF_STATUS_REPORT variances above this: unhealthy
    pose_stale_s: float  # a yaw older than this (autopilot time) forms no pose
    bounds: TelemetryBounds  # beyond these a pose value is absurd and rejected


def link_limits(safety: SafetyConfig | LinkLimits) -> LinkLimits:
    """The link's numbers from a safety configuration (a LinkLimits is taken as is)."""
    if isinstance(safety, LinkLimits):
        return safety
    return LinkLimits(
        heartbeat_timeout_s=safety.heartbeat_timeout_s,
        ekf_variance_max=safety.ekf_variance_max,
        pose_stale_s=safety.pose_stale_s,
        bounds=TelemetryBounds(
            position_max_m=safety.telemetry_position_max_m,
            speed_max_mps=safety.telemetry_speed_max_mps,
            yaw_max_rad=safety.telemetry_yaw_max_rad,
        ),
    )
