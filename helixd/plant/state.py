"""The simulated rover's physical state (NED world, body velocities, scroll speeds, pit), shared
by the physics step and the obstacle contact model."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class PhysicsState:
    north_m: float = 0.0
    east_m: float = 0.0
    yaw_ned_rad: float = 0.0
    vx_body_mps: float = 0.0  # achieved, ROLL axis
    vy_body_mps: float = 0.0  # achieved, SCROLL axis (left)
    wz_body_radps: float = 0.0  # achieved, CCW positive
    scroll_radps: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    pit_depth: float = 0.0  # 0 = free, 1 = dug in
    odometer_m: float = 0.0

    @property
    def yaw_rate_ned_radps(self) -> float:
        return -self.wz_body_radps

    @property
    def v_north_mps(self) -> float:
        c, s = math.cos(self.yaw_ned_rad), math.sin(self.yaw_ned_rad)
        return self.vx_body_mps * c + self.vy_body_mps * s

    @property
    def v_east_mps(self) -> float:
        c, s = math.cos(self.yaw_ned_rad), math.sin(self.yaw_ned_rad)
        return self.vx_body_mps * s - self.vy_body_mps * c

    @property
    def speed_mps(self) -> float:
        return math.hypot(self.vx_body_mps, self.vy_body_mps)
