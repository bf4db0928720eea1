"""Fraction ⇄ PWM per channel, and the RC_CHANNELS_OVERRIDE field semantics."""

from __future__ import annotations

import math

import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from helixd.actuators.mapping import (
    fraction_to_pwm,
    frame_at,
    leave_unchanged_value,
    override_slots,
    pwm_to_fraction,
    release_frame,
    release_value,
)
from helixd.config.vehicle import ChannelConfig

STD = ChannelConfig(channel=1)
ASYM = ChannelConfig(channel=2, pwm_min_us=1100, pwm_trim_us=1520, pwm_max_us=1900)


def test_standard_channel_ends_and_middle() -> None:
    assert fraction_to_pwm(0.0, STD) == 1500
    assert fraction_to_pwm(1.0, STD) == 2000
    assert fraction_to_pwm(-1.0, STD) == 1000
    assert fraction_to_pwm(0.5, STD) == 1750
    assert fraction_to_pwm(-0.25, STD) == 1375


def test_asymmetric_trim_uses_each_side_span() -> None:
    assert fraction_to_pwm(0.5, ASYM) == 1520 + 190
    assert fraction_to_pwm(-0.5, ASYM) == 1520 - 210


def test_reverse_swaps_min_and_max() -> None:
    rev = ChannelConfig(channel=3, reversed=True)
    assert fraction_to_pwm(1.0, rev) == 1000
    assert fraction_to_pwm(-1.0, rev) == 2000
    assert fraction_to_pwm(0.3, rev) == fraction_to_pwm(-0.3, STD)


def test_deadband_sends_trim() -> None:
    db = ChannelConfig(channel=4, deadband_us=30)
    assert fraction_to_pwm(0.05, db) == 1500  # 25 µs < 30
    assert fraction_to_pwm(-0.05, db) == 1500
    assert fraction_to_pwm(0.06, db) == 1530  # 30 µs is outside the deadband
    assert pwm_to_fraction(1520, db) == 0.0


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_is_neutral(bad: float) -> None:
    assert fraction_to_pwm(bad, STD) == 1500


def test_out_of_range_is_clamped() -> None:
    assert fraction_to_pwm(3.0, STD) == 2000
    assert fraction_to_pwm(-7.0, ASYM) == 1100


channels = st.builds(
    lambda lo, trim_off, hi_off, rev, db: ChannelConfig(
        channel=1,
        pwm_min_us=lo,
        pwm_trim_us=lo + trim_off,
        pwm_max_us=min(2200, lo + trim_off + hi_off),
        reversed=rev,
        deadband_us=db,
    ),
    st.integers(800, 1400),
    st.integers(50, 400),
    st.integers(50, 500),
    st.booleans(),
    st.integers(0, 40),
)
fractions = st.floats(-1.5, 1.5, allow_nan=False)


@given(channels, fractions)
def test_pwm_always_within_limits(ch: ChannelConfig, f: float) -> None:
    assume(ch.pwm_trim_us < ch.pwm_max_us)
    assert ch.pwm_min_us <= fraction_to_pwm(f, ch) <= ch.pwm_max_us


@given(channels, fractions, fractions)
def test_monotonic_in_the_wired_direction(ch: ChannelConfig, a: float, b: float) -> None:
    assume(ch.pwm_trim_us < ch.pwm_max_us and a <= b)
    pa, pb = fraction_to_pwm(a, ch), fraction_to_pwm(b, ch)
    assert (pa >= pb) if ch.reversed else (pa <= pb)


@given(channels, st.floats(-1.0, 1.0, allow_nan=False))
def test_inverse_round_trips_to_one_microsecond(ch: ChannelConfig, f: float) -> None:
    assume(ch.pwm_trim_us < ch.pwm_max_us)
    pwm = fraction_to_pwm(f, ch)
    back = pwm_to_fraction(pwm, ch)
    assert fraction_to_pwm(back, ch) == pwm
    if pwm != ch.pwm_trim_us:  # outside the deadband the fraction survives up to rounding
        side = (
            ch.pwm_max_us - ch.pwm_trim_us
            if pwm > ch.pwm_trim_us
            else (ch.pwm_trim_us - ch.pwm_min_us)
        )
        assert abs(back - f) <= 0.5 / side + 1e-9


def test_leave_unchanged_and_release_values_per_mavlink_spec() -> None:
    for ch in range(1, 9):
        assert leave_unchanged_value(ch) == 65535
        assert release_value(ch) == 0
    for ch in range(9, 19):
        assert leave_unchanged_value(ch) == 0
        assert release_value(ch) == 65534


def test_override_frame_leaves_other_channels_alone() -> None:
    values_us = {1: 1600, 3: 1400, 10: 1700, 18: 1100}
    frame = frame_at(override_slots(values_us), list(values_us.values()))
    assert len(frame) == 18
    assert frame[0] == 1600 and frame[2] == 1400 and frame[9] == 1700 and frame[17] == 1100
    assert [frame[i] for i in (1, 3, 4, 5, 6, 7)] == [65535] * 6
    assert [frame[i] for i in (8, 10, 11, 12, 13, 14, 15, 16)] == [0] * 8


def test_release_frame_releases_only_ours() -> None:
    frame = release_frame([2, 12])
    assert frame[1] == 0 and frame[11] == 65534
    assert frame[0] == 65535 and frame[8] == 0 and frame[17] == 0


def test_channel_range_is_checked() -> None:
    with pytest.raises(ValueError, match=r"outside 1\.\.18"):
        override_slots([19])


@given(
    st.dictionaries(st.integers(1, 18), st.integers(800, 2200), min_size=1, max_size=18),
)
def test_slots_once_then_frames_equal_the_checked_frame(values_us: dict[int, int]) -> None:
    """The sink's path (channels checked once, PWMs placed per command): our PWMs on our
    channels, "leave unchanged" (65535 on 1..8, 0 on 9..18) elsewhere."""
    slots = override_slots(values_us)
    expected = [values_us.get(ch, 65535 if ch <= 8 else 0) for ch in range(1, 19)]
    assert frame_at(slots, list(values_us.values())) == tuple(expected)


def test_override_slots_check_the_channels() -> None:
    assert override_slots([1, 4, 18]) == (0, 3, 17)
    with pytest.raises(ValueError, match=r"outside 1\.\.18"):
        override_slots([0])
