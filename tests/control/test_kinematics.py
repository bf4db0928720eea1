"""Scroll kinematics: eq. 1/2, mode constraints, joint saturation, per-scroll calibration."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helixd.base.geometry import BodyVelocity
from helixd.base.plan import MotionMode
from helixd.config.vehicle import ScrollCalibration, VehicleConfig
from helixd.control.kinematics import (
    apply_calibration,
    body_to_fractions,
    body_to_scroll_radps,
    constrain,
    forward_matrix,
    fraction_to_radps,
    inverse_matrix,
    no_slip_body_velocity,
    radps_to_fraction,
    radps_to_rpm,
    rpm_to_radps,
    saturate,
    saturate4,
    scroll_fractions,
    scroll_radps_to_body,
)

VEHICLE = VehicleConfig()
R, K = VEHICLE.scroll_radius_m, VEHICLE.lx_m + VEHICLE.ly_m

speeds = st.floats(min_value=-3.0, max_value=3.0, allow_nan=False)
rates = st.floats(min_value=-5.0, max_value=5.0, allow_nan=False)
bodies = st.builds(BodyVelocity, speeds, speeds, rates)
fraction = st.floats(min_value=-2.0, max_value=2.0, allow_nan=False)
four_fractions = st.lists(fraction, min_size=4, max_size=4).map(np.array)
clamps = st.floats(min_value=0.05, max_value=1.0)


def _close(a: BodyVelocity, b: BodyVelocity, tol: float = 1e-9) -> bool:
    return (
        math.isclose(a.vx_mps, b.vx_mps, abs_tol=tol)
        and math.isclose(a.vy_mps, b.vy_mps, abs_tol=tol)
        and math.isclose(a.wz_radps, b.wz_radps, abs_tol=tol)
    )


# -- eq. 1 / eq. 2 ----------------------------------------------------------------------------


@settings(deadline=None)
@given(bodies)
def test_inverse_then_forward_is_identity(body: BodyVelocity) -> None:
    omega = body_to_scroll_radps(body, VEHICLE)
    assert _close(scroll_radps_to_body(omega, VEHICLE), body)


def test_forward_times_inverse_is_the_3x3_identity() -> None:
    product = forward_matrix(R, VEHICLE.lx_m, VEHICLE.ly_m) @ inverse_matrix(
        R, VEHICLE.lx_m, VEHICLE.ly_m
    )
    assert np.allclose(product, np.eye(3))


def test_eq2_by_hand() -> None:
    # ω1 = (v_x + v_y + (l_x+l_y) v_θ)/r, ω2 = (v_x − v_y + k v_θ)/r, ω3 = (−v_x − v_y + k v_θ)/r,
    # ω4 = (−v_x + v_y + k v_θ)/r
    vx, vy, wz = 0.3, -0.2, 0.4
    omega = body_to_scroll_radps(BodyVelocity(vx, vy, wz), VEHICLE)
    expected = [
        (vx + vy + K * wz) / R,
        (vx - vy + K * wz) / R,
        (-vx - vy + K * wz) / R,
        (-vx + vy + K * wz) / R,
    ]
    assert omega == pytest.approx(expected)


def test_pure_roll_drives_the_sides_against_each_other() -> None:
    omega = body_to_scroll_radps(BodyVelocity(0.5, 0.0, 0.0), VEHICLE)
    assert omega == pytest.approx([0.5 / R, 0.5 / R, -0.5 / R, -0.5 / R])


def test_rpm_and_fraction_conversions_round_trip() -> None:
    assert rpm_to_radps(60.0) == pytest.approx(2 * math.pi)
    assert radps_to_rpm(rpm_to_radps(195.0)) == pytest.approx(195.0)
    omega = np.array([1.0, -2.0, 3.0, -4.0])
    frac = radps_to_fraction(omega, 195.0)
    assert frac[2] == pytest.approx(3.0 / rpm_to_radps(195.0))
    assert fraction_to_radps(frac, 195.0) == pytest.approx(omega)


# -- mode constraints -------------------------------------------------------------------------


@settings(deadline=None)
@given(bodies)
def test_modes_remove_their_forbidden_component(body: BodyVelocity) -> None:
    def realised(mode: MotionMode) -> BodyVelocity:
        return scroll_radps_to_body(body_to_scroll_radps(constrain(body, mode), VEHICLE), VEHICLE)

    roll, scroll, omni = (realised(m) for m in MotionMode)
    assert roll.vy_mps == pytest.approx(0.0, abs=1e-9)
    assert roll.vx_mps == pytest.approx(body.vx_mps) and roll.wz_radps == pytest.approx(
        body.wz_radps
    )
    assert scroll.vx_mps == pytest.approx(0.0, abs=1e-9)
    assert scroll.vy_mps == pytest.approx(body.vy_mps)
    assert omni.wz_radps == pytest.approx(0.0, abs=1e-9)
    assert (omni.vx_mps, omni.vy_mps) == pytest.approx((body.vx_mps, body.vy_mps))


# -- saturation -------------------------------------------------------------------------------


@settings(deadline=None)
@given(four_fractions, clamps)
def test_saturation_respects_the_clamp_and_keeps_direction(f: np.ndarray, clamp: float) -> None:
    out = saturate(f, clamp)
    assert float(np.max(np.abs(out))) <= clamp * (1 + 1e-12)
    # Parallel to the input with a non-negative scale ≤ 1: out = s·f.
    peak = float(np.max(np.abs(f)))
    if peak == 0.0:
        assert np.all(out == 0.0)
        return
    scale = min(1.0, clamp / peak)
    assert out == pytest.approx(scale * f, abs=1e-12)
    # And the direction of the body motion it produces is unchanged.
    before = forward_matrix(R, VEHICLE.lx_m, VEHICLE.ly_m) @ f
    after = forward_matrix(R, VEHICLE.lx_m, VEHICLE.ly_m) @ out
    assert after == pytest.approx(scale * before, abs=1e-9)


def test_saturation_leaves_small_commands_alone() -> None:
    f = np.array([0.1, -0.2, 0.3, -0.4])
    assert saturate(f, 0.9) == pytest.approx(f)
    assert saturate(np.array([1.8, 0.9, 0.0, -0.9]), 0.9) == pytest.approx([0.9, 0.45, 0.0, -0.45])


@settings(deadline=None)
@given(bodies)
def test_full_pipeline_stays_within_the_clamp_and_the_mode(body: BodyVelocity) -> None:
    for mode in MotionMode:
        fractions = body_to_fractions(body, VEHICLE, mode)
        assert float(np.max(np.abs(fractions))) <= VEHICLE.output_clamp + 1e-12
        realised = scroll_radps_to_body(fraction_to_radps(fractions, VEHICLE.max_rpm), VEHICLE)
        wanted = constrain(body, mode)
        # Default calibration is the identity: realised = s · wanted with 0 < s ≤ 1.
        w = np.array([wanted.vx_mps, wanted.vy_mps, wanted.wz_radps])
        r = np.array([realised.vx_mps, realised.vy_mps, realised.wz_radps])
        if np.linalg.norm(w) < 1e-12:
            assert np.allclose(r, 0.0)
            continue
        s = float(np.dot(r, w) / np.dot(w, w))
        assert 0.0 < s <= 1.0 + 1e-9
        assert r == pytest.approx(s * w, abs=1e-9)


# -- calibration ------------------------------------------------------------------------------


def _cal(**kw: float | bool) -> tuple[ScrollCalibration, ...]:
    return (ScrollCalibration(**kw),) * 4


def test_default_calibration_is_the_identity() -> None:
    f = np.array([0.5, -0.25, 0.0, 0.9])
    assert apply_calibration(f, _cal(), 0.9) == pytest.approx(f)


def test_calibration_gain_and_offset_follow_v_equals_a_w_plus_b() -> None:
    # applied = gain·f + sign(f)·offset
    out = apply_calibration(np.array([0.4, -0.4, 0.1, -0.1]), _cal(gain=1.5, offset=0.05), 0.9)
    assert out == pytest.approx([0.65, -0.65, 0.2, -0.2])


def test_calibration_deadband_sends_zero_below_it() -> None:
    out = apply_calibration(np.array([0.04, -0.04, 0.05, -0.3]), _cal(deadband=0.05), 0.9)
    assert out == pytest.approx([0.0, 0.0, 0.05, -0.3])


def test_calibration_zero_stays_zero_even_with_offset() -> None:
    out = apply_calibration(np.zeros(4), _cal(offset=0.1), 0.9)
    assert np.all(out == 0.0)


def test_calibration_reversed_negates_per_scroll() -> None:
    cals = (
        ScrollCalibration(reversed=True),
        ScrollCalibration(),
        ScrollCalibration(reversed=True, gain=2.0),
        ScrollCalibration(),
    )
    out = apply_calibration(np.array([0.3, 0.3, 0.3, -0.3]), cals, 0.9)
    assert out == pytest.approx([-0.3, 0.3, -0.6, -0.3])


@settings(deadline=None)
@given(four_fractions, st.floats(0.5, 2.0), st.floats(0.0, 0.3), st.booleans())
def test_calibrated_output_respects_the_clamp(
    f: np.ndarray, gain: float, offset: float, reversed_: bool
) -> None:
    out = apply_calibration(f, _cal(gain=gain, offset=offset, reversed=reversed_), 0.9)
    assert float(np.max(np.abs(out))) <= 0.9
    # Sign follows the command (flipped when reversed), never inverted by the offset.
    for fi, oi in zip(f, out, strict=True):
        if oi != 0.0:
            assert (oi > 0) == ((fi > 0) != reversed_)


# -- the plain-float path the control loop runs agrees with the matrix form --------------------


def _matrix_fractions(body: BodyVelocity, vehicle: VehicleConfig, mode: MotionMode) -> np.ndarray:
    """Eq. 2 with the 4×3 matrix, then the numpy saturation and calibration."""
    omega = body_to_scroll_radps(constrain(body, mode), vehicle)
    f = saturate(radps_to_fraction(omega, vehicle.max_rpm), vehicle.output_clamp)
    return apply_calibration(f, vehicle.scrolls, vehicle.output_clamp)


calibrated_vehicles = st.builds(
    lambda gain, offset, deadband, rev: VehicleConfig(
        scrolls=[
            ScrollCalibration(gain=gain, offset=offset, deadband=deadband, reversed=rev),
            ScrollCalibration(),
            ScrollCalibration(reversed=not rev),
            ScrollCalibration(gain=gain),
        ]
    ),
    st.floats(0.5, 2.0),
    st.floats(0.0, 0.2),
    st.floats(0.0, 0.1),
    st.booleans(),
)


@settings(deadline=None)
@given(bodies, st.sampled_from(list(MotionMode)), calibrated_vehicles)
def test_scroll_fractions_equal_the_matrix_pipeline(
    body: BodyVelocity, mode: MotionMode, vehicle: VehicleConfig
) -> None:
    plain = scroll_fractions(body, vehicle, mode)
    assert isinstance(plain, tuple) and all(type(x) is float for x in plain)
    assert plain == pytest.approx(_matrix_fractions(body, vehicle, mode).tolist(), abs=1e-12)
    assert body_to_fractions(body, vehicle, mode).tolist() == list(plain)


@settings(deadline=None)
@given(bodies, st.sampled_from(list(MotionMode)))
def test_no_slip_body_velocity_equals_eq1_of_the_saturated_fractions(
    body: BodyVelocity, mode: MotionMode
) -> None:
    omega = body_to_scroll_radps(constrain(body, mode), VEHICLE)
    f = saturate(radps_to_fraction(omega, VEHICLE.max_rpm), VEHICLE.output_clamp)
    want = scroll_radps_to_body(fraction_to_radps(f, VEHICLE.max_rpm), VEHICLE)
    got = no_slip_body_velocity(body, VEHICLE, mode)
    assert _close(got, want, tol=1e-12)


@settings(deadline=None)
@given(four_fractions, clamps)
def test_saturate4_equals_saturate(f: np.ndarray, clamp: float) -> None:
    four = (float(f[0]), float(f[1]), float(f[2]), float(f[3]))
    assert list(saturate4(four, clamp)) == pytest.approx(saturate(f, clamp).tolist(), abs=1e-15)
