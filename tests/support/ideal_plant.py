"""An ideal kinematic plant for control tests: no slip, no lag, no noise.

    ẋ = v_x cos ψ − v_y sin ψ,   ẏ = v_x sin ψ + v_y cos ψ,   ψ̇ = ω_z

integrated with the midpoint heading ψ + ω_z·dt/2 (second order for a constant command).

With ``vehicle`` given, the command first goes through the real scroll pipeline —
mode constraint → eq. 2 → fraction of max RPM → joint saturation → calibration
(:func:`body_to_fractions`) → rad/s → eq. 1 — so the plant moves with what the four scrolls
can actually do, saturation included. Eq. 1 is the simulator's own
(:func:`helixd.plant.forward.body_velocity`), not the controller's: a sign error in the
controller's kinematics moves this plant the wrong way too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from helixd.base.angles import wrap_pi
from helixd.base.geometry import BodyVelocity, Pose2D
from helixd.base.plan import MotionMode
from helixd.config.vehicle import VehicleConfig
from helixd.control.kinematics import body_to_fractions, constrain, fraction_to_radps
from helixd.plant.forward import body_velocity


def integrate(pose: Pose2D, body: BodyVelocity, dt_s: float) -> Pose2D:
    """Move ``pose`` by the body-frame velocity ``body`` for ``dt_s`` seconds."""
    yaw_mid = pose.yaw_rad + 0.5 * body.wz_radps * dt_s
    c, s = math.cos(yaw_mid), math.sin(yaw_mid)
    return Pose2D(
        x_m=pose.x_m + (body.vx_mps * c - body.vy_mps * s) * dt_s,
        y_m=pose.y_m + (body.vx_mps * s + body.vy_mps * c) * dt_s,
        yaw_rad=wrap_pi(pose.yaw_rad + body.wz_radps * dt_s),
    )


@dataclass
class IdealPlant:
    """Holds the true pose and the clock; ``step`` applies one command for one period."""

    pose: Pose2D
    mode: MotionMode
    vehicle: VehicleConfig | None = None
    t_s: float = 0.0

    def realised(self, command: BodyVelocity) -> BodyVelocity:
        """The body velocity the plant actually performs for ``command``."""
        if self.vehicle is None:
            return constrain(command, self.mode)
        fractions = body_to_fractions(command, self.vehicle, self.mode)
        omega_radps = fraction_to_radps(fractions, self.vehicle.max_rpm)
        v = self.vehicle
        return body_velocity(omega_radps, v.scroll_radius_m, v.lx_m, v.ly_m)

    def step(self, command: BodyVelocity, dt_s: float) -> Pose2D:
        self.pose = integrate(self.pose, self.realised(command), dt_s)
        self.t_s += dt_s
        return self.pose
