"""wrap_pi and shortest_angular_distance (thesis Algorithm 1, sign fixed)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helixd.base.angles import shortest_angular_distance, wrap_pi

angles = st.floats(min_value=-1e4, max_value=1e4, allow_nan=False, allow_infinity=False)


@settings(deadline=None)
@given(angles)
def test_wrap_pi_lands_in_half_open_interval(a: float) -> None:
    w = wrap_pi(a)
    assert -math.pi < w <= math.pi


@settings(deadline=None)
@given(angles)
def test_wrap_pi_is_idempotent(a: float) -> None:
    w = wrap_pi(a)
    assert wrap_pi(w) == w


@settings(deadline=None)
@given(angles)
def test_wrap_pi_keeps_the_direction(a: float) -> None:
    w = wrap_pi(a)
    # Same point on the unit circle (tolerance grows with |a|: a + 2πk loses low bits).
    tol = 1e-12 * max(1.0, abs(a))
    assert math.cos(w) == pytest.approx(math.cos(a), abs=tol)
    assert math.sin(w) == pytest.approx(math.sin(a), abs=tol)


@pytest.mark.parametrize(
    ("angle", "expected"),
    [
        (math.pi, math.pi),
        (-math.pi, math.pi),  # the interval is open at −π
        (3 * math.pi, math.pi),
        (-3 * math.pi, math.pi),
        (2 * math.pi, 0.0),
        (1.5 * math.pi, -0.5 * math.pi),
        (-1.5 * math.pi, 0.5 * math.pi),
        (0.25, 0.25),
    ],
)
def test_wrap_pi_known_values(angle: float, expected: float) -> None:
    assert wrap_pi(angle) == pytest.approx(expected, abs=1e-12)


@settings(deadline=None)
@given(angles, angles)
def test_shortest_distance_takes_from_onto_to(a: float, b: float) -> None:
    d = shortest_angular_distance(a, b)
    assert -math.pi < d <= math.pi
    tol = 1e-11 * max(1.0, abs(a), abs(b))
    assert math.cos(a + d) == pytest.approx(math.cos(b), abs=tol)
    assert math.sin(a + d) == pytest.approx(math.sin(b), abs=tol)


def test_shortest_distance_crosses_pi_the_short_way() -> None:
    # From 170° to −170° is +20°, not −340°.
    d = shortest_angular_distance(math.radians(170), math.radians(-170))
    assert d == pytest.approx(math.radians(20))
    assert shortest_angular_distance(math.radians(-170), math.radians(170)) == pytest.approx(
        math.radians(-20)
    )


def test_shortest_distance_sign_reads_goal_minus_current() -> None:
    # Goal to the left (CCW) of the current heading → positive (turn CCW).
    assert shortest_angular_distance(0.0, 0.5) == pytest.approx(0.5)
    assert shortest_angular_distance(0.5, 0.0) == pytest.approx(-0.5)


@settings(deadline=None)
@given(st.floats(min_value=-math.pi, max_value=math.pi, exclude_min=True))
def test_wrap_pi_leaves_angles_inside_the_interval_bit_exact(a: float) -> None:
    assert wrap_pi(a) == a
