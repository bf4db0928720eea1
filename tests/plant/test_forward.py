"""The simulator is an independent oracle for the controller's kinematics.

The sim's plant integrates its own eq. 1 (:mod:`helixd.plant.forward`); the controller builds
eq. 2 (and eq. 1) as matrices in :mod:`helixd.control.kinematics`. Commands from the
controller's inverse kinematics must move the simulated rover the way they ask — and a
deliberately sign-flipped inverse kinematics (alone, or flipped together with the controller's
own forward matrix so that the controller's round trip still holds) must make the simulated
rover go the wrong way, i.e. fail the same check.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as hs

import helixd.control.kinematics as kin
from helixd.base.geometry import BodyVelocity, NonFiniteError
from helixd.base.plan import MotionMode
from helixd.config.vehicle import VehicleConfig
from helixd.plant import forward
from helixd.plant.ground import Terrain
from helixd.plant.physics import step
from helixd.plant.plant_config import PlantConfig
from helixd.plant.state import PhysicsState

VEHICLE = VehicleConfig()
R, LX, LY = VEHICLE.scroll_radius_m, VEHICLE.lx_m, VEHICLE.ly_m
DT_S = 0.02
TAU_S = 0.3
HARD = PlantConfig().terrains.get(Terrain.HARD)

Fractions = Callable[[BodyVelocity, MotionMode], np.ndarray]


def xyz(v: BodyVelocity) -> tuple[float, float, float]:
    return (v.vx_mps, v.vy_mps, v.wz_radps)


# -- eq. 1 by hand -----------------------------------------------------------------------------


def test_eq1_pure_roll_scroll_and_turn() -> None:
    w = 2.0
    assert xyz(forward.body_velocity((w, w, -w, -w), R, LX, LY)) == pytest.approx((R * w, 0, 0))
    assert xyz(forward.body_velocity((w, -w, -w, w), R, LX, LY)) == pytest.approx((0, R * w, 0))
    turn = forward.body_velocity((w, w, w, w), R, LX, LY)
    assert xyz(turn) == pytest.approx((0.0, 0.0, R * w / (LX + LY)))


def test_eq1_is_linear_in_each_scroll() -> None:
    # scroll 1 alone: +x, +y and CCW at once, r/4 each (r/(4(lx+ly)) for the turn)
    v = forward.body_velocity((4.0, 0.0, 0.0, 0.0), R, LX, LY)
    assert (v.vx_mps, v.vy_mps, v.wz_radps) == pytest.approx((R, R, R / (LX + LY)))
    v = forward.body_velocity((0.0, 0.0, 4.0, 0.0), R, LX, LY)  # scroll 3: −x, −y, CCW
    assert (v.vx_mps, v.vy_mps, v.wz_radps) == pytest.approx((-R, -R, R / (LX + LY)))


def test_eq1_refuses_non_finite_speeds() -> None:
    with pytest.raises(NonFiniteError):
        forward.body_velocity((math.nan, 0.0, 0.0, 0.0), R, LX, LY)


def test_rpm_conversion() -> None:
    assert forward.rpm_to_radps(60.0) == pytest.approx(2.0 * math.pi)
    assert forward.radps_to_rpm(forward.rpm_to_radps(195.0)) == pytest.approx(195.0)


speed = hs.floats(min_value=-0.5, max_value=0.5)


@given(vx=speed, vy=speed, wz=hs.floats(min_value=-0.8, max_value=0.8))
def test_controller_eq2_inverts_the_simulators_eq1(vx: float, vy: float, wz: float) -> None:
    omega = kin.body_to_scroll_radps(BodyVelocity(vx, vy, wz), VEHICLE)
    back = forward.body_velocity(omega, R, LX, LY)
    assert (back.vx_mps, back.vy_mps, back.wz_radps) == pytest.approx((vx, vy, wz), abs=1e-9)


# -- the controller's commands, flown in the simulator's plant --------------------------------


def fly(fractions: np.ndarray, seconds: float) -> PhysicsState:
    state = PhysicsState()  # at the origin, facing North
    f = tuple(float(x) for x in fractions)
    for _ in range(round(seconds / DT_S)):
        state = step(state, DT_S, f, VEHICLE, HARD, TAU_S)
    return state


def wrong_ways(to_fractions: Fractions) -> list[str]:
    """Drive the simulated rover with commands from ``to_fractions``; name every motion that
    went another way than the command asked (facing North: body +x = North, +y = West,
    CCW = yaw_ned decreasing)."""
    wrong: list[str] = []
    s = fly(to_fractions(BodyVelocity(0.3, 0.0, 0.0), MotionMode.ROLL), 3.0)
    if not (s.north_m > 0.1 and abs(s.east_m) < 0.05 and abs(s.yaw_ned_rad) < 0.05):
        wrong.append(f"ROLL forward ended at N {s.north_m:.2f} E {s.east_m:.2f}")
    s = fly(to_fractions(BodyVelocity(0.0, 0.3, 0.0), MotionMode.SCROLL), 3.0)
    if not (s.east_m < -0.05 and abs(s.north_m) < 0.02):  # hard ground: scroll 0.12
        wrong.append(f"SCROLL left ended at N {s.north_m:.2f} E {s.east_m:.2f}")
    s = fly(to_fractions(BodyVelocity(0.0, 0.0, 0.5), MotionMode.ROLL), 1.0)
    if not (s.yaw_ned_rad < -0.2 and math.hypot(s.north_m, s.east_m) < 0.05):
        wrong.append(f"turn CCW ended at yaw_ned {s.yaw_ned_rad:.2f}")
    return wrong


def controller(body: BodyVelocity, mode: MotionMode) -> np.ndarray:
    return kin.body_to_fractions(body, VEHICLE, mode)


def test_the_controllers_kinematics_move_the_simulated_rover_as_commanded() -> None:
    assert wrong_ways(controller) == []


def _flip_yaw(matrix: np.ndarray, column: bool) -> np.ndarray:
    out = matrix.copy()
    if column:
        out[:, 2] *= -1.0  # eq. 2: the (l_x+l_y)·v_θ terms
    else:
        out[2, :] *= -1.0  # eq. 1: the v_θ row
    out.setflags(write=False)
    return out


def test_a_sign_flipped_inverse_kinematics_goes_the_wrong_way(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    real = kin.inverse_matrix

    def flipped_x(r: float, lx: float, ly: float) -> np.ndarray:
        out = real(r, lx, ly).copy()
        out[:, 0] *= -1.0  # v_x enters every scroll with the wrong sign
        return out

    monkeypatch.setattr(kin, "inverse_matrix", flipped_x)
    assert any("ROLL forward" in w for w in wrong_ways(controller))


def test_a_consistently_flipped_controller_fails_against_the_simulator(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Yaw sign flipped in both of the controller's matrices: its own eq. 2 → eq. 1 round trip
    still holds (a plant built from them would agree), but the simulator's eq. 1 turns the
    rover the other way."""
    real_inv, real_fwd = kin.inverse_matrix, kin.forward_matrix
    monkeypatch.setattr(kin, "inverse_matrix", lambda *g: _flip_yaw(real_inv(*g), True))
    monkeypatch.setattr(kin, "forward_matrix", lambda *g: _flip_yaw(real_fwd(*g), False))
    body = BodyVelocity(0.1, 0.2, 0.3)
    round_trip = kin.scroll_radps_to_body(kin.body_to_scroll_radps(body, VEHICLE), VEHICLE)
    assert xyz(round_trip) == pytest.approx(xyz(body))  # the controller cannot see its own error
    wrong = wrong_ways(controller)
    assert any("turn CCW" in w for w in wrong), wrong
