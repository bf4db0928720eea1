"""Helix-25 ground physics (pure): PWM → scroll speed with motor lag → eq. 1 with terrain slip.

Frames: body x = ROLL axis (forward), y = SCROLL axis (LEFT), yaw counter-clockwise positive
(the thesis's convention; eq. 1 is the simulator's own, :mod:`helixd.plant.forward`).
World: NED, yaw clockwise from North.
A CCW body yaw rate is a negative NED yaw rate; body y-left at NED heading ψ points to ψ − 90°:
    v_north = v_x cos ψ + v_y sin ψ,   v_east = v_x sin ψ − v_y cos ψ.

Slip: each body axis passes only a terrain-dependent fraction of the no-slip velocity. Slip
(commanded-by-the-scrolls minus achieved, plus the 'scrolls fighting' null-space part of the
four speeds) digs a pit where the terrain allows it (dry sand, thesis Field Test 1: turning in
place in SCROLL mode dug the scrolls in and the rover could not turn); a pit scales every
axis by (1 − depth) and is left behind by actually travelling. The ``stalled`` fault makes the
rover dig in completely while it lasts: the scrolls keep turning, the rover does not move.

Media by place: :func:`step` takes one traction for the whole rover, or four, one per scroll
(the medium under each, :func:`scroll_positions_ne`). With four, each scroll's own term of
eq. 1 is scaled by its own medium's per-axis efficiency before the terms are summed, so a
rover with every scroll in one medium moves as with that one traction, and a rover straddling
a boundary gets a blend: driving ROLL with its right scrolls on the bank and its left ones
afloat, it moves at the mean roll efficiency and yaws towards the water (the bank side pushes
harder). Pit digging and escaping use the mean of the four rates.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

from helixd.base.angles import wrap_pi
from helixd.config.vehicle import VehicleConfig
from helixd.plant.forward import body_velocity, rpm_to_radps
from helixd.plant.ground import TerrainTraction
from helixd.plant.state import PhysicsState


@dataclass(frozen=True, slots=True)
class MotorMap:
    """Helix motor controller: PWM → signed fraction of max RPM."""

    pwm_min_us: int = 1000
    pwm_trim_us: int = 1500
    pwm_max_us: int = 2000
    deadband_us: int = 0

    def fraction(self, pwm_us: int) -> float:
        if pwm_us <= 0:
            return 0.0  # no pulses: the controller stops the motor
        delta = pwm_us - self.pwm_trim_us
        if abs(delta) <= self.deadband_us:
            return 0.0
        if delta > 0:
            return min(1.0, delta / (self.pwm_max_us - self.pwm_trim_us))
        return max(-1.0, delta / (self.pwm_trim_us - self.pwm_min_us))


def scroll_fractions_from_pwm(
    outputs_us: Sequence[int],
    channels: Sequence[int],
    reversed_: Sequence[bool],
    motor: MotorMap,
) -> tuple[float, float, float, float]:
    """Servo outputs (16, 1-based ``channels``) → the four scroll speed commands."""
    fr = [motor.fraction(int(outputs_us[ch - 1])) for ch in channels]
    fr = [-f if rev else f for f, rev in zip(fr, reversed_, strict=True)]
    return (fr[0], fr[1], fr[2], fr[3])


# Scroll centres in the body frame (x forward, y left), in units of (l_x, l_y): read off eq. 1
# and eq. 2 as a mecanum X layout (docs/physics.md): scroll 1 front right, 2 rear right, 3 rear
# left, 4 front left ({1, 2} on the right, as ROLL's skid-steer has it).
SCROLL_CORNERS: tuple[tuple[float, float], ...] = (
    (1.0, -1.0),
    (-1.0, -1.0),
    (-1.0, 1.0),
    (1.0, 1.0),
)


def scroll_positions_ne(
    north_m: float, east_m: float, yaw_ned_rad: float, vehicle: VehicleConfig
) -> tuple[tuple[float, float], ...]:
    """(north_m, east_m) of the four scroll centres, scrolls 1..4, at (±l_x, ±l_y) in the body
    frame of a rover at this pose (NED yaw, clockwise from North)."""
    c, s = math.cos(yaw_ned_rad), math.sin(yaw_ned_rad)
    out = []
    for fx, fy in SCROLL_CORNERS:
        x, y = fx * vehicle.lx_m, fy * vehicle.ly_m
        out.append((north_m + x * c + y * s, east_m + x * s - y * c))
    return tuple(out)


def _per_scroll_velocity(
    omega: Sequence[float], vehicle: VehicleConfig, tractions: Sequence[TerrainTraction]
) -> tuple[float, float, float]:
    """Eq. 1 term by term, each scroll's term scaled by its own medium's efficiencies."""
    vx = vy = wz = 0.0
    for i, (w, t) in enumerate(zip(omega, tractions, strict=True)):
        alone = [0.0, 0.0, 0.0, 0.0]
        alone[i] = w
        term = body_velocity(alone, vehicle.scroll_radius_m, vehicle.lx_m, vehicle.ly_m)
        vx += term.vx_mps * t.roll_efficiency
        vy += term.vy_mps * t.scroll_efficiency
        wz += term.wz_radps * t.yaw_efficiency
    return vx, vy, wz


def step(
    state: PhysicsState,
    dt_s: float,
    scroll_fractions: Sequence[float],
    vehicle: VehicleConfig,
    traction: TerrainTraction | Sequence[TerrainTraction],
    motor_time_constant_s: float,
    stalled: bool = False,
) -> PhysicsState:
    """Advance the rover by ``dt_s`` seconds. ``traction``: the ground under the whole rover,
    or four, the medium under each of scrolls 1..4 (see the module docstring)."""
    omega_max = rpm_to_radps(vehicle.max_rpm)
    alpha = 1.0 - math.exp(-dt_s / motor_time_constant_s)
    omega = tuple(
        w + (max(-1.0, min(1.0, f)) * omega_max - w) * alpha
        for w, f in zip(state.scroll_radps, scroll_fractions, strict=True)
    )
    ideal = body_velocity(omega, vehicle.scroll_radius_m, vehicle.lx_m, vehicle.ly_m)
    k = vehicle.lx_m + vehicle.ly_m
    free = 0.0 if stalled else max(0.0, 1.0 - state.pit_depth)
    if isinstance(traction, TerrainTraction):
        vx = ideal.vx_mps * traction.roll_efficiency * free
        vy = ideal.vy_mps * traction.scroll_efficiency * free
        wz = ideal.wz_radps * traction.yaw_efficiency * free
        dig_rate_per_m = traction.dig_rate_per_m
        pit_escape_per_m = traction.pit_escape_per_m
    else:
        if len(traction) != 4:
            raise ValueError(f"need one traction or four (one per scroll), got {len(traction)}")
        vx, vy, wz = (v * free for v in _per_scroll_velocity(omega, vehicle, traction))
        dig_rate_per_m = sum(t.dig_rate_per_m for t in traction) / 4.0
        pit_escape_per_m = sum(t.pit_escape_per_m for t in traction) / 4.0
    # speed the scrolls "push" that produces no motion: per-axis loss plus the null space
    # of eq. 1 (ω1 − ω2 + ω3 − ω4: scrolls fighting each other)
    fighting = abs(omega[0] - omega[1] + omega[2] - omega[3]) * vehicle.scroll_radius_m / 4.0
    slip_mps = math.hypot(ideal.vx_mps - vx, ideal.vy_mps - vy) + k * abs(ideal.wz_radps - wz)
    slip_mps += fighting
    travelled_m = math.hypot(vx, vy) * dt_s
    pit = state.pit_depth + dig_rate_per_m * slip_mps * dt_s
    pit = max(0.0, min(1.0, pit - pit_escape_per_m * travelled_m))
    # midpoint heading for the translation, CCW body rate = −NED yaw rate
    yaw_mid = state.yaw_ned_rad - 0.5 * wz * dt_s
    c, s = math.cos(yaw_mid), math.sin(yaw_mid)
    return replace(
        state,
        north_m=state.north_m + (vx * c + vy * s) * dt_s,
        east_m=state.east_m + (vx * s - vy * c) * dt_s,
        yaw_ned_rad=wrap_pi(state.yaw_ned_rad - wz * dt_s),
        vx_body_mps=vx,
        vy_body_mps=vy,
        wz_body_radps=wz,
        scroll_radps=(omega[0], omega[1], omega[2], omega[3]),
        pit_depth=pit,
        odometer_m=state.odometer_m + travelled_m,
    )
