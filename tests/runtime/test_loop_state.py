"""The flight loop's bookkeeping, in numbers: the control-rate ceiling as a schedule kept in
autopilot time, the yaw rate from successive poses, the crew's state's defaults.
(:func:`helixd.runtime.loop_state.ceiling_next_due` itself: tests/runtime/test_flight.py.)"""

from __future__ import annotations

import itertools
import math

import pytest

from helixd.runtime.loop_state import (
    CEILING_JITTER_FRACTION,
    CrewState,
    StepCeiling,
    YawRateMeter,
)
from helixd.runtime.mode_gate import Gate


def test_the_ceiling_takes_the_first_pose_and_counts_from_it() -> None:
    ceiling = StepCeiling(0.02)  # 50 Hz
    assert ceiling.early_s == pytest.approx(CEILING_JITTER_FRACTION * 0.02)
    assert ceiling.take(10.0)
    assert (ceiling.last_s, ceiling.due_s) == (10.0, pytest.approx(10.02))


def test_the_ceiling_thins_a_flood_to_its_own_rate() -> None:
    ceiling = StepCeiling(0.02)
    flood = [k * 0.004 for k in range(500)]  # 250 Hz for 2 s
    taken = [t for t in flood if ceiling.take(t)]
    # 50 Hz: the steps due at 0, 0.02, …, 2.00 s (each pose 4 ms early of its step is taken)
    assert len(taken) == 101 and taken[1] == pytest.approx(0.016)
    gaps = [b - a for a, b in itertools.pairwise(taken)]
    assert min(gaps) >= 0.02 - ceiling.early_s - 1e-9  # never closer than the jitter allows
    assert (taken[-1] - taken[0]) / len(gaps) == pytest.approx(0.02, rel=0.01)


def test_the_ceiling_takes_a_slightly_early_pose_but_not_one_too_early() -> None:
    ceiling = StepCeiling(0.02)
    assert ceiling.take(1.0)
    assert ceiling.take(1.0 + 0.02 - 0.004)  # 4 ms early, within a quarter period (5 ms)
    assert not ceiling.take(1.016 + 0.02 - 0.006 - 0.004)  # 6 ms before due: thinned
    assert ceiling.last_s == pytest.approx(1.016)


def test_the_ceiling_restarts_after_a_reboot_and_after_a_gap() -> None:
    ceiling = StepCeiling(0.02)
    assert ceiling.take(100.0)
    assert ceiling.take(3.0)  # the autopilot rebooted: its clock ran backwards
    assert ceiling.due_s == pytest.approx(3.02)
    assert ceiling.take(4.0)  # a second without poses: restarted from this one
    assert ceiling.due_s == pytest.approx(4.02)


def test_the_yaw_rate_is_counter_clockwise_positive_and_wraps() -> None:
    meter = YawRateMeter()
    meter.update(0.0, 0.1)
    assert meter.radps == 0.0  # one pose: no rate yet
    meter.update(0.5, 0.0)  # compass yaw falling: turning counter-clockwise
    assert meter.radps == pytest.approx(0.2)
    meter.update(1.0, math.pi - 0.05)  # through ±π the short way round
    meter.update(1.1, -math.pi + 0.05)
    assert meter.radps == pytest.approx(-1.0)


def test_the_yaw_rate_ignores_a_repeated_time_and_a_nan_yaw() -> None:
    meter = YawRateMeter()
    meter.update(1.0, 0.0)
    meter.update(2.0, -0.5)
    assert meter.radps == pytest.approx(0.5)
    meter.update(2.0, -1.0)  # same time: no rate from it, but the pose is kept
    assert meter.radps == pytest.approx(0.5) and meter.previous == (2.0, -1.0)
    meter.update(3.0, math.nan)
    assert meter.previous == (2.0, -1.0) and meter.radps == pytest.approx(0.5)


def test_the_crew_state_starts_driving_with_nothing_seen() -> None:
    crew = CrewState()
    assert crew.gate is Gate.DRIVE and crew.walk_items == ()
    assert (crew.item, crew.step, crew.arrived) == (None, None, False)
