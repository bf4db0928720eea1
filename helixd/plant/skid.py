"""ArduPilot SITL's skid-steer rover (``--model rover-skid``) as a plant (pure).

Written from ArduPilot's ``libraries/SITL/SIM_Rover.cpp`` / ``SIM_Rover.h`` (``SimRover``), so
that the built-in simulator can stand in for real Rover SITL with the same setup as
``tests/sitl`` (outputs 1 and 3 are the motors). Deliberately independent of
:mod:`helixd.control`: the simulator is meant to be an oracle for helixd, not a copy of it.

What SIM_Rover.cpp does for a skid-steering frame (frame string containing ``"skid"``; read
in the current ``update()`` → ``update_ackermann_or_skid()`` and in the older single
``update()``, which agree on every equation used here):

* constructor: ``max_speed = 4`` (m/s) and ``max_accel = 14`` (m/s²) for skid steering
  ("taken from a 6V wild thumper with skid steering, with a sabertooth controller");
  ``skid_turn_rate = 140`` (°/s); SIM_Rover.h: ``MAX_YAW_RATE = 360`` °/s.
* inputs: ``motor1 = servos[0] ? normalise_servo_input(servos[0]) : 0`` (output 1, left
  motor), ``motor2`` the same from ``servos[2]`` (output 3, right motor), with
  ``normalise_servo_input(pwm) = 2*((pwm-1000)/1000 - 0.5)``; an output at 0 (no pulses) is a
  stopped motor. ``diff_steering = motor1 - motor2``, ``throttle = 0.5*(motor1 + motor2)``.
  Outputs 2 and 4 are not read. No clamp of the PWM (SERVOn_MIN/MAX bound the outputs).
* ``calc_yaw_rate()`` for skid: ``constrain(diff_steering * skid_turn_rate, ±MAX_YAW_RATE)``
  °/s, independent of speed (the rover turns in place; the limit never binds for
  1000–2000 µs: ≤ 280 °/s). ``gyro = (0, 0, radians(yaw_rate))`` in the body frame (z down):
  positive = clockwise seen from above, i.e. the left motor faster turns the rover right.
* speed: ``speed = (dcm^T · velocity_ef).x`` (body forward); ``target_speed = throttle *
  max_speed``; ``accel = max_accel * (target_speed - speed) / max_speed`` — a first-order lag
  with time constant max_speed/max_accel = 4/14 s ≈ 0.286 s.
* integration per physics frame (``frame_time_us``; SIM_Aircraft.h ``rate_hz = 1200``):
  ``dcm.rotate(gyro*dt)`` first, then ``accel_body = (accel, radians(yaw_rate)*speed, 0)``
  (forward plus the centripetal term that turns the velocity with the body), rotated to earth
  with the *new* attitude (``accel_earth = dcm * accel_body``, z zeroed on the ground);
  ``velocity_ef += accel_earth*dt``; ``position += velocity_ef*dt`` (semi-implicit Euler).
  No side slip model beyond that, no terrain. (The frame rate hardly matters: 50 Hz instead
  of 1200 Hz moves a 10 s S-turn's end by 3 cm.)

Steady state therefore: forward speed = ½(m1+m2)·4 m/s, NED yaw rate = (m1−m2)·140 °/s.

helixd additions (not in SIM_Rover.cpp): the simulator's ``stall`` fault holds the rover
still (velocity and yaw rate zero) while it lasts. Terrain traction does not apply. The state
is the Helix plant's :class:`PhysicsState` (velocity kept in the body frame, y left, yaw rate
counter-clockwise), so estimator, telemetry and snapshots work unchanged; its scroll speeds
and pit depth stay 0 (a skid rover has neither).
"""

from __future__ import annotations

import math
from dataclasses import replace

from helixd.plant.state import PhysicsState

LEFT_OUTPUT = 1  # servos[0]: motor1
RIGHT_OUTPUT = 3  # servos[2]: motor2
_TWO_PI = 2.0 * math.pi


def motor_command(pwm_us: int) -> float:
    """SIM_Rover's ``normalise_servo_input``: 1000 → −1, 1500 → 0, 2000 → +1; 0 (no pulses) → 0."""
    if pwm_us <= 0:
        return 0.0
    return 2.0 * ((pwm_us - 1000) / 1000.0 - 0.5)


def steering_throttle(left_us: int, right_us: int) -> tuple[float, float]:
    """(steering, throttle) of SIM_Rover.cpp's skid branch from outputs 1 (left) and 3 (right)."""
    m1 = motor_command(left_us)
    m2 = motor_command(right_us)
    return m1 - m2, 0.5 * (m1 + m2)


def yaw_rate_ned_radps(steering: float, turn_rate_dps: float, max_yaw_rate_dps: float) -> float:
    """calc_yaw_rate() for skid steering, in rad/s, clockwise positive (NED)."""
    rate_dps = max(-max_yaw_rate_dps, min(max_yaw_rate_dps, steering * turn_rate_dps))
    return math.radians(rate_dps)


def _wrap_pi(angle_rad: float) -> float:
    return (angle_rad + math.pi) % _TWO_PI - math.pi


def step(
    state: PhysicsState,
    dt_s: float,
    left_us: int,
    right_us: int,
    *,
    max_speed_mps: float,
    max_accel_mss: float,
    turn_rate_dps: float,
    max_yaw_rate_dps: float,
    physics_rate_hz: float,
    stalled: bool = False,
) -> PhysicsState:
    """Advance SIM_Rover's skid model by ``dt_s`` in frames of at most 1/physics_rate_hz s.

    Total: a non-finite or non-positive ``dt_s`` returns ``state`` unchanged.
    """
    if not math.isfinite(dt_s) or dt_s <= 0.0:
        return state
    if stalled:
        return replace(state, vx_body_mps=0.0, vy_body_mps=0.0, wz_body_radps=0.0)
    steering, throttle = steering_throttle(left_us, right_us)
    yaw_rate = yaw_rate_ned_radps(steering, turn_rate_dps, max_yaw_rate_dps)
    target_speed = throttle * max_speed_mps
    frames = max(1, math.ceil(dt_s * physics_rate_hz - 1e-9))
    h = dt_s / frames
    yaw = state.yaw_ned_rad
    vn, ve = state.v_north_mps, state.v_east_mps
    north, east, odo = state.north_m, state.east_m, state.odometer_m
    for _ in range(frames):
        speed = vn * math.cos(yaw) + ve * math.sin(yaw)  # body x of velocity_ef
        accel = max_accel_mss * (target_speed - speed) / max_speed_mps
        yaw += yaw_rate * h  # dcm.rotate(gyro * delta_time)
        c, s = math.cos(yaw), math.sin(yaw)
        lateral = yaw_rate * speed  # accel_body.y (body y = right in NED)
        vn += (accel * c - lateral * s) * h
        ve += (accel * s + lateral * c) * h
        north += vn * h
        east += ve * h
        odo += math.hypot(vn, ve) * h
    yaw = _wrap_pi(yaw)
    c, s = math.cos(yaw), math.sin(yaw)
    return replace(
        state,
        north_m=north,
        east_m=east,
        yaw_ned_rad=yaw,
        vx_body_mps=vn * c + ve * s,
        vy_body_mps=vn * s - ve * c,  # PhysicsState's y is LEFT
        wz_body_radps=-yaw_rate,  # PhysicsState's yaw rate is counter-clockwise positive
        odometer_m=odo,
    )
