"""Helix-25 scroll kinematics (thesis eq. 1 and eq. 2), as numpy matrices.

Body frame: x = ROLL axis, y = SCROLL axis, z up, yaw CCW positive. Scrolls 1..4 as in the
thesis's Fig. 2. ω in rad/s; a *scroll fraction* is ω / ω_max, signed, ω_max = max_rpm.

Total: the command pipeline (:func:`body_to_fractions`, :func:`saturate`,
:func:`apply_calibration`) turns any non-finite value into neutral (all four scrolls 0: a
direction cannot be kept from a NaN), never into the clamp; the plain matrix conversions raise
:class:`NonFiniteError` on non-finite input.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from helixd.base.geometry import BodyVelocity, require_finite
from helixd.base.plan import MotionMode
from helixd.control.params import ScrollCalibrationParams, VehicleParams

FloatArray = npt.NDArray[np.float64]

RPM_PER_RADPS = 60.0 / (2.0 * math.pi)


@functools.lru_cache(maxsize=8)
def inverse_matrix(radius_m: float, lx_m: float, ly_m: float) -> FloatArray:
    """Eq. 2: [ω1 ω2 ω3 ω4]ᵀ = J⁺ · [v_x v_y v_θ]ᵀ (4×3)."""
    k = lx_m + ly_m
    # cached per geometry (the control loop calls this every step): never mutate the result
    return _frozen(
        (1.0 / radius_m)
        * np.array(
            [
                [1.0, 1.0, k],
                [1.0, -1.0, k],
                [-1.0, -1.0, k],
                [-1.0, 1.0, k],
            ]
        )
    )


@functools.lru_cache(maxsize=8)
def forward_matrix(radius_m: float, lx_m: float, ly_m: float) -> FloatArray:
    """Eq. 1: [v_x v_y v_θ]ᵀ = J · [ω1 ω2 ω3 ω4]ᵀ (3×4)."""
    k = lx_m + ly_m
    return _frozen(
        (radius_m / 4.0)
        * np.array(
            [
                [1.0, 1.0, -1.0, -1.0],
                [1.0, -1.0, -1.0, 1.0],
                [1.0 / k, 1.0 / k, 1.0 / k, 1.0 / k],
            ]
        )
    )


def _frozen(a: FloatArray) -> FloatArray:
    a.setflags(write=False)
    return a


def body_to_scroll_radps(body: BodyVelocity, vehicle: VehicleParams) -> FloatArray:
    """Inverse kinematics: body velocity → four scroll speeds (rad/s)."""
    require_finite("body velocity", body.vx_mps, body.vy_mps, body.wz_radps)
    j_inv = inverse_matrix(vehicle.scroll_radius_m, vehicle.lx_m, vehicle.ly_m)
    omega: FloatArray = j_inv @ np.array([body.vx_mps, body.vy_mps, body.wz_radps])
    return omega


def scroll_radps_to_body(
    omega_radps: Sequence[float] | FloatArray, vehicle: VehicleParams
) -> BodyVelocity:
    """Forward kinematics: four scroll speeds (rad/s) → body velocity (no slip)."""
    j = forward_matrix(vehicle.scroll_radius_m, vehicle.lx_m, vehicle.ly_m)
    omega = np.asarray(omega_radps, dtype=np.float64)
    require_finite("scroll speeds", *(float(w) for w in omega))
    vx, vy, wz = j @ omega
    return BodyVelocity(float(vx), float(vy), float(wz))


def rpm_to_radps(rpm: float) -> float:
    return rpm / RPM_PER_RADPS


def radps_to_rpm(radps: float) -> float:
    return radps * RPM_PER_RADPS


def radps_to_fraction(omega_radps: FloatArray, max_rpm: float) -> FloatArray:
    """Scroll speed → signed fraction of the max RPM."""
    return np.asarray(omega_radps, dtype=np.float64) / rpm_to_radps(max_rpm)


def fraction_to_radps(fraction: FloatArray, max_rpm: float) -> FloatArray:
    return np.asarray(fraction, dtype=np.float64) * rpm_to_radps(max_rpm)


def constrain(body: BodyVelocity, mode: MotionMode) -> BodyVelocity:
    """Apply the motion mode's constraint: ROLL v_y = 0, SCROLL v_x = 0, OMNI ω_z = 0."""
    if mode is MotionMode.ROLL:
        return BodyVelocity(body.vx_mps, 0.0, body.wz_radps)
    if mode is MotionMode.SCROLL:
        return BodyVelocity(0.0, body.vy_mps, body.wz_radps)
    return BodyVelocity(body.vx_mps, body.vy_mps, 0.0)


def saturate(fractions: FloatArray, clamp: float) -> FloatArray:
    """Scale all four scrolls together so the largest |fraction| is at most ``clamp``.

    Scaling (rather than clipping each scroll) keeps the direction of the body motion.
    """
    f = np.asarray(fractions, dtype=np.float64)
    if not np.all(np.isfinite(f)):
        return np.zeros_like(f)
    peak = float(np.max(np.abs(f))) if f.size else 0.0
    if peak <= clamp or peak == 0.0:
        return f.copy()
    return f * (clamp / peak)


def apply_calibration(
    fractions: FloatArray, scrolls: Sequence[ScrollCalibrationParams], clamp: float
) -> FloatArray:
    """Per-scroll v = a·ω + b correction, deadband and wiring direction; result clamped.

    A fraction inside the deadband is sent as 0 (the motor would not turn anyway).
    """
    out = np.zeros(4, dtype=np.float64)
    for i, (f, cal) in enumerate(
        zip(np.asarray(fractions, dtype=np.float64), scrolls, strict=True)
    ):
        if not math.isfinite(f) or abs(f) < cal.deadband or f == 0.0:
            continue
        value = cal.gain * f + math.copysign(cal.offset, f)
        value = max(-clamp, min(clamp, value))
        out[i] = -value if cal.reversed else value
    return out


def body_to_fractions(body: BodyVelocity, vehicle: VehicleParams, mode: MotionMode) -> FloatArray:
    """The full pipeline: mode constraint → eq. 2 → fraction of max RPM → joint saturation →
    per-scroll calibration. Returns four fractions in [−clamp, clamp]; all four 0 (neutral)
    when any component of ``body`` is not finite."""
    if not body.is_finite():
        return np.zeros(4, dtype=np.float64)
    with np.errstate(over="ignore", invalid="ignore"):  # an absurd body overflows: neutral
        omega = body_to_scroll_radps(constrain(body, mode), vehicle)
        fractions = saturate(radps_to_fraction(omega, vehicle.max_rpm), vehicle.output_clamp)
    return apply_calibration(fractions, vehicle.scrolls, vehicle.output_clamp)
