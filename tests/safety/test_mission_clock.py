"""The mission time limit's clock: driving time only, on the later of both clocks."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from helixd.safety.mission_clock import MissionClock, MissionTime, PausedTime


def test_the_time_after_a_paused_update_counts_as_paused() -> None:
    p = PausedTime()
    assert p.update(0.0, False) == 0.0
    assert p.update(10.0, True) == 0.0  # driven from 0 to 10, paused from now on
    assert p.update(25.0, True) == 15.0
    assert p.update(30.0, False) == 20.0  # paused until 30, driving from now on
    assert p.update(100.0, False) == 20.0


def test_a_clock_that_runs_backwards_adds_nothing_and_counts_on_from_there() -> None:
    p = PausedTime()
    p.update(50.0, True)
    assert p.update(2.0, True) == 0.0  # the autopilot rebooted
    assert p.update(5.0, False) == 3.0
    assert p.update(math.nan, True) == 3.0  # never a non-finite count
    assert p.update(6.0, True) == 3.0  # the NaN left the last state as it was


def test_the_mission_time_is_the_later_clock_less_its_own_pause() -> None:
    c = MissionClock()
    assert c.update(0.0, None, False) == MissionTime(0.0, 0.0)
    assert c.update(1.0, 0.0, False) == MissionTime(1.0, 0.0)
    # a simulator at 4×: the autopilot's clock is ahead
    assert c.update(2.0, 4.0, True) == MissionTime(4.0, 0.0)
    assert c.update(12.0, 44.0, False) == MissionTime(4.0, 40.0)  # 10 s of wall time in HOLD
    assert c.update(13.0, 48.0, False) == MissionTime(8.0, 40.0)


def test_after_an_autopilot_reboot_the_wall_clock_still_counts() -> None:
    c = MissionClock()
    c.update(0.0, 0.0, False)
    c.update(100.0, 100.0, False)
    assert c.update(101.0, -95.0, False) == MissionTime(101.0, 0.0)  # its clock restarted


@given(
    st.lists(
        st.tuples(st.floats(0.0, 10.0), st.floats(0.0, 10.0), st.booleans()),
        min_size=1,
        max_size=50,
    )
)
def test_driving_and_paused_add_up_to_the_clock_and_never_shrink(
    steps: list[tuple[float, float, bool]],
) -> None:
    c = MissionClock()
    wall_s = vehicle_s = 0.0
    last = MissionTime(0.0, 0.0)
    for dwall_s, dvehicle_s, paused in steps:
        wall_s += dwall_s
        vehicle_s += dvehicle_s
        now = c.update(wall_s, vehicle_s, paused)
        assert now.paused_s >= 0.0 and now.driving_s >= 0.0
        # the time on the clock it counts on, split into driving and paused
        total_s = now.driving_s + now.paused_s
        assert total_s == pytest.approx(wall_s) or total_s == pytest.approx(vehicle_s)
        assert now.driving_s >= last.driving_s - 1e-9  # the limit's time never goes back
        last = now


def test_never_paused_is_the_later_of_both_clocks_as_before() -> None:
    c = MissionClock()
    for wall_s, vehicle_s in [(0.0, 0.0), (1.0, 3.0), (5.0, 4.0), (6.0, 9.5)]:
        assert c.update(wall_s, vehicle_s, False) == MissionTime(max(wall_s, vehicle_s), 0.0)
