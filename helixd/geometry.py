"""Plain value types shared by the control core and the I/O shell.

The control core works in a right-handed planar *mission frame*: x and y in metres,
yaw in radians counter-clockwise from +x (the thesis's ROS convention). Which mission
frame that is (start / local_ned / global) is decided once, in :mod:`helixd.frames`.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class Pose2D:
    """Planar pose in the mission frame."""

    x_m: float
    y_m: float
    yaw_rad: float


@dataclass(frozen=True, slots=True)
class BodyVelocity:
    """Body-frame velocity command: x = ROLL axis, y = SCROLL axis, z up (CCW positive)."""

    vx_mps: float = 0.0
    vy_mps: float = 0.0
    wz_radps: float = 0.0

    @staticmethod
    def zero() -> BodyVelocity:
        return BodyVelocity(0.0, 0.0, 0.0)
