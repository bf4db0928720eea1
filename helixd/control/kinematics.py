"""Helix-25 scroll kinematics (thesis eq. 1 and eq. 2).

Body frame: x = ROLL axis, y = SCROLL axis, z up, yaw CCW positive. Scrolls 1..4 as in the
thesis's Fig. 2. ω in rad/s; a *scroll fraction* is ω / ω_max, signed, ω_max = max_rpm.

Two faces of the same equations. The control loop's path (:func:`scroll_fractions`,
:func:`no_slip_body_velocity` and the ``*4`` helpers) is written out in plain floats: on four
numbers numpy costs more in call and allocation overhead than the arithmetic itself (a
control step used to spend ~130 µs in it). The numpy functions (:func:`inverse_matrix`,
:func:`body_to_scroll_radps`, :func:`body_to_fractions`, ...) are the matrix form of the same
maths for tests, tools and analysis; the tests check that the two agree.

Total: the command pipeline (:func:`body_to_fractions` / :func:`scroll_fractions`,
:func:`saturate`, :func:`apply_calibration`) turns any non-finite value into neutral (all four
scrolls 0: a direction cannot be kept from a NaN), never into the clamp; the plain matrix
conversions raise :class:`NonFiniteError` on non-finite input.
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
Fractions4 = tuple[float, float, float, float]  # scrolls 1..4

RPM_PER_RADPS = 60.0 / (2.0 * math.pi)
NEUTRAL4: Fractions4 = (0.0, 0.0, 0.0, 0.0)


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
    f = [float(x) for x in np.asarray(fractions, dtype=np.float64)]
    if len(f) != len(scrolls):
        raise ValueError(f"{len(f)} fractions for {len(scrolls)} scrolls")
    return np.array([_calibrated(x, cal, clamp) for x, cal in zip(f, scrolls, strict=True)])


def body_to_fractions(body: BodyVelocity, vehicle: VehicleParams, mode: MotionMode) -> FloatArray:
    """:func:`scroll_fractions` as a numpy array (four fractions in [−clamp, clamp]; all four
    0 (neutral) when any component of ``body`` is not finite)."""
    return np.array(scroll_fractions(body, vehicle, mode), dtype=np.float64)


# -- the control loop's path, in plain floats -------------------------------------------------


def _constrained(vx: float, vy: float, wz: float, mode: MotionMode) -> tuple[float, float, float]:
    """:func:`constrain` on three floats."""
    if mode is MotionMode.ROLL:
        return vx, 0.0, wz
    if mode is MotionMode.SCROLL:
        return 0.0, vy, wz
    return vx, vy, 0.0


def _saturated_fractions4(vx: float, vy: float, wz: float, vehicle: VehicleParams) -> Fractions4:
    """Eq. 2 (ω = J⁺·v, the rows of :func:`inverse_matrix`), then fraction of the max RPM,
    then the joint saturation; neutral when any of it is not finite (an absurd command
    overflows to inf, and inf − inf is NaN)."""
    j_inv = _rows(inverse_matrix(vehicle.scroll_radius_m, vehicle.lx_m, vehicle.ly_m))
    omega_max_radps = rpm_to_radps(vehicle.max_rpm)
    f1, f2, f3, f4 = ((a * vx + b * vy + c * wz) / omega_max_radps for a, b, c in j_inv)
    return saturate4((f1, f2, f3, f4), vehicle.output_clamp)


_Rows = tuple[tuple[float, ...], ...]
_ROWS_OF: dict[int, tuple[FloatArray, _Rows]] = {}
_ROWS_CACHE_MAX = 16


def _rows(matrix: FloatArray) -> _Rows:
    """A (frozen, cached) kinematics matrix as rows of plain floats: the plain-float path
    uses the very coefficients of :func:`inverse_matrix` / :func:`forward_matrix`, one
    definition of the equations. Cached per matrix object (held, so its id stays unique)."""
    hit = _ROWS_OF.get(id(matrix))
    if hit is None or hit[0] is not matrix:
        if len(_ROWS_OF) >= _ROWS_CACHE_MAX:
            _ROWS_OF.clear()
        hit = (matrix, tuple(tuple(float(x) for x in row) for row in matrix.tolist()))
        _ROWS_OF[id(matrix)] = hit
    return hit[1]


def saturate4(f: Fractions4, clamp: float) -> Fractions4:
    """:func:`saturate` on four floats: scaled together so the largest |f| ≤ ``clamp``;
    neutral when any is not finite."""
    f1, f2, f3, f4 = f
    peak = max(abs(f1), abs(f2), abs(f3), abs(f4))
    if not math.isfinite(peak) or math.isnan(f1 + f2 + f3 + f4):
        return NEUTRAL4  # max() may skip a NaN, the sum never does
    if peak <= clamp or peak == 0.0:
        return f1, f2, f3, f4
    k = clamp / peak
    return f1 * k, f2 * k, f3 * k, f4 * k


def _calibrated(f: float, cal: ScrollCalibrationParams, clamp: float) -> float:
    """One scroll's v = a·ω + b, deadband, clamp and wiring direction; 0 for a non-finite f."""
    if not math.isfinite(f) or abs(f) < cal.deadband or f == 0.0:
        return 0.0
    value = cal.gain * f + math.copysign(cal.offset, f)
    value = max(-clamp, min(clamp, value))
    return -value if cal.reversed else value


def scroll_fractions(body: BodyVelocity, vehicle: VehicleParams, mode: MotionMode) -> Fractions4:
    """The full pipeline: mode constraint → eq. 2 → fraction of max RPM → joint saturation →
    per-scroll calibration. Returns four fractions in [−clamp, clamp]; all four 0 (neutral)
    when any component of ``body`` is not finite."""
    vx, vy, wz = body.vx_mps, body.vy_mps, body.wz_radps
    if not (math.isfinite(vx) and math.isfinite(vy) and math.isfinite(wz)):
        return NEUTRAL4
    f1, f2, f3, f4 = _saturated_fractions4(*_constrained(vx, vy, wz, mode), vehicle)
    s1, s2, s3, s4 = vehicle.scrolls
    clamp = vehicle.output_clamp
    return (
        _calibrated(f1, s1, clamp),
        _calibrated(f2, s2, clamp),
        _calibrated(f3, s3, clamp),
        _calibrated(f4, s4, clamp),
    )


def no_slip_body_velocity(
    body: BodyVelocity, vehicle: VehicleParams, mode: MotionMode
) -> BodyVelocity:
    """The body velocity the scrolls produce on ideal ground for the command ``body``: the
    mode's constraint and the joint saturation of :func:`scroll_fractions` applied, then
    eq. 1 (the per-scroll calibration is the actuators' business, not the ground's). Zero for
    a non-finite command (the pipeline sends neutral then)."""
    vx, vy, wz = body.vx_mps, body.vy_mps, body.wz_radps
    if not (math.isfinite(vx) and math.isfinite(vy) and math.isfinite(wz)):
        return BodyVelocity(0.0, 0.0, 0.0)
    f1, f2, f3, f4 = _saturated_fractions4(*_constrained(vx, vy, wz, mode), vehicle)
    # eq. 1 on ω = f·ω_max: v = J·ω (the rows of forward_matrix)
    j = _rows(forward_matrix(vehicle.scroll_radius_m, vehicle.lx_m, vehicle.ly_m))
    omega_max_radps = rpm_to_radps(vehicle.max_rpm)
    w1, w2, w3, w4 = (
        f1 * omega_max_radps,
        f2 * omega_max_radps,
        f3 * omega_max_radps,
        f4 * omega_max_radps,
    )
    out_vx, out_vy, out_wz = (a * w1 + b * w2 + c * w3 + d * w4 for a, b, c, d in j)
    if not (math.isfinite(out_vx) and math.isfinite(out_vy) and math.isfinite(out_wz)):
        return BodyVelocity(0.0, 0.0, 0.0)
    return BodyVelocity(out_vx, out_vy, out_wz)
