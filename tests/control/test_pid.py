"""PID: terms, output limit, anti-windup, derivative on measurement, reset, dt ≤ 0."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helixd.config.control import PidGains
from helixd.control.pid import PID, PidTerms

DT = 0.025  # 40 Hz


def gains(kp: float = 0.0, ki: float = 0.0, kd: float = 0.0, limit: float = 1.0) -> PidGains:
    return PidGains(kp=kp, ki=ki, kd=kd, integral_limit=limit)


def test_terms_add_up_to_the_output() -> None:
    pid = PID(gains(kp=2.0, ki=1.0, kd=0.5), output_limit=100.0)
    pid.update(10.0, 4.0, DT)  # first step: no derivative yet
    terms = pid.update(10.0, 5.0, DT)
    assert terms.p == pytest.approx(2.0 * 5.0)
    assert terms.i == pytest.approx(1.0 * (6.0 + 5.0) * DT)
    assert terms.d == pytest.approx(-0.5 * (5.0 - 4.0) / DT)
    assert terms.output == pytest.approx(terms.p + terms.i + terms.d)


def test_pid_terms_are_frozen() -> None:
    terms = PidTerms.zero()
    with pytest.raises(AttributeError):
        terms.p = 1.0  # type: ignore[misc]


@settings(deadline=None)
@given(
    st.floats(-1e3, 1e3),
    st.floats(-1e3, 1e3),
    st.floats(0.0, 100.0),
    st.floats(0.01, 10.0),
)
def test_output_never_exceeds_the_limit(
    setpoint: float, measurement: float, kp: float, limit: float
) -> None:
    pid = PID(gains(kp=kp, ki=1.0, kd=1.0), output_limit=limit)
    for k in range(5):
        out = pid.update(setpoint, measurement + k, DT).output
        assert -limit <= out <= limit


def test_integral_never_exceeds_integral_limit() -> None:
    # Output limit far away so only the integral clamp acts.
    pid = PID(gains(ki=5.0, limit=0.3), output_limit=100.0)
    for _ in range(2000):
        terms = pid.update(1.0, 0.0, DT)
    assert terms.i == pytest.approx(0.3)
    assert abs(pid.integral) <= 0.3


def test_long_saturated_error_does_not_wind_up_and_recovers_fast() -> None:
    # kp alone saturates the output at 1.0; integrating would only push further.
    pid = PID(gains(kp=2.0, ki=0.5, limit=5.0), output_limit=1.0)
    for _ in range(40 * 60):  # one minute stuck at a large error
        terms = pid.update(10.0, 0.0, DT)
        assert terms.output == 1.0
    assert pid.integral == pytest.approx(0.0)  # frozen: saturated the same way
    # The error changes sign: the output follows within one step, no windup to unwind.
    terms = pid.update(0.0, 0.2, DT)
    assert terms.output < 0.0


def test_windup_comparison_with_a_naive_integrator() -> None:
    # A naive integrator would hold ki·e·t = 0.5·10·60 = 300 after this minute. Here P = 0.5
    # leaves 0.5 of headroom below the output limit, and the clamp stops the integral at 0.4.
    pid = PID(gains(kp=0.05, ki=0.5, limit=0.4), output_limit=1.0)
    for _ in range(40 * 60):
        terms = pid.update(10.0, 0.0, DT)
    assert pid.integral == pytest.approx(0.4)
    assert terms.output == pytest.approx(0.9)


def test_integration_stops_at_saturation_and_resumes_when_the_error_reverses() -> None:
    pid = PID(gains(kp=0.1, ki=1.0, limit=5.0), output_limit=1.0)
    for _ in range(40 * 30):
        terms = pid.update(1.0, 0.0, DT)
    # Frozen once P + I reached the limit: I ≈ 1.0 − P, not the integral_limit of 5.
    assert terms.output == 1.0
    assert pid.integral == pytest.approx(1.0 - 0.1, abs=1.0 * DT)
    wound = pid.integral
    pid.update(-1.0, 0.0, DT)  # error reversed: integration works against the saturation
    assert pid.integral < wound


def test_derivative_on_measurement_no_kick_on_setpoint_jump() -> None:
    pid = PID(gains(kp=1.0, kd=2.0), output_limit=100.0)
    pid.update(0.0, 0.0, DT)
    before = pid.update(0.0, 0.0, DT)
    jumped = pid.update(5.0, 0.0, DT)  # setpoint jumps, measurement steady
    assert jumped.d == 0.0
    assert jumped.output == pytest.approx(before.output + 5.0)  # only P moved


def test_derivative_opposes_measurement_motion() -> None:
    pid = PID(gains(kd=1.0), output_limit=100.0)
    pid.update(0.0, 0.0, DT)
    terms = pid.update(0.0, 0.1, DT)  # measurement rising at 4 units/s
    assert terms.d == pytest.approx(-4.0)


def test_angular_derivative_wraps_across_pi() -> None:
    pid = PID(gains(kd=1.0), output_limit=100.0, angular=True)
    pid.update(math.pi, math.pi - 0.01, DT)
    terms = pid.update(math.pi, -math.pi + 0.01, DT)  # crossed ±π: moved +0.02 rad
    assert terms.d == pytest.approx(-0.02 / DT)


def test_angular_error_is_the_shortest_way() -> None:
    pid = PID(gains(kp=1.0), output_limit=100.0, angular=True)
    terms = pid.update(math.radians(-170), math.radians(170), DT)
    assert terms.p == pytest.approx(math.radians(20))


def test_reset_forgets_integral_and_derivative_memory() -> None:
    pid = PID(gains(ki=1.0, kd=1.0, limit=1.0), output_limit=10.0)
    for k in range(100):
        pid.update(1.0, 0.01 * k, DT)
    assert pid.integral > 0.0
    pid.reset()
    assert pid.integral == 0.0
    terms = pid.update(1.0, 50.0, DT)  # a huge measurement jump right after reset: no D kick
    assert terms.d == 0.0


@pytest.mark.parametrize("dt", [0.0, -0.1, math.nan, math.inf])
def test_bad_dt_skips_integral_and_derivative(dt: float) -> None:
    pid = PID(gains(kp=1.0, ki=1.0, kd=1.0), output_limit=10.0)
    pid.update(1.0, 0.0, DT)
    integral = pid.integral
    terms = pid.update(1.0, 0.5, dt)
    assert terms.d == 0.0
    assert pid.integral == integral
    assert terms.p == pytest.approx(0.5)
    assert math.isfinite(terms.output)


def test_zero_ki_never_integrates() -> None:
    pid = PID(gains(kp=1.0, ki=0.0, limit=1.0), output_limit=10.0)
    for _ in range(100):
        terms = pid.update(1.0, 0.0, DT)
    assert terms.i == 0.0


def test_output_limit_must_be_positive() -> None:
    with pytest.raises(ValueError, match="output_limit"):
        PID(gains(kp=1.0), output_limit=0.0)
