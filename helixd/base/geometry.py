"""Plain value types shared by the control core and the I/O shell.

The control core works in a right-handed planar *mission frame*: x and y in metres,
yaw in radians counter-clockwise from +x (the thesis's ROS convention). Which mission
frame that is (start / local_ned / global) is decided once, in :mod:`helixd.base.frames`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


class NonFiniteError(ValueError):
    """A NaN/inf reached a function of the control core that cannot give a safe answer."""


def require_finite(what: str, *values: float) -> None:
    """Raise :class:`NonFiniteError` unless every value is a finite number."""
    for v in values:
        if not math.isfinite(v):
            raise NonFiniteError(f"{what} is not finite: {values}")


@dataclass(frozen=True, slots=True)
class Pose2D:
    """Planar pose in the mission frame."""

    x_m: float
    y_m: float
    yaw_rad: float

    def is_finite(self) -> bool:
        return math.isfinite(self.x_m) and math.isfinite(self.y_m) and math.isfinite(self.yaw_rad)


@dataclass(frozen=True, slots=True)
class BodyVelocity:
    """Body-frame velocity command: x = ROLL axis, y = SCROLL axis, z up (CCW positive)."""

    vx_mps: float = 0.0
    vy_mps: float = 0.0
    wz_radps: float = 0.0

    @staticmethod
    def zero() -> BodyVelocity:
        return BodyVelocity(0.0, 0.0, 0.0)

    def is_finite(self) -> bool:
        return (
            math.isfinite(self.vx_mps)
            and math.isfinite(self.vy_mps)
            and math.isfinite(self.wz_radps)
        )
