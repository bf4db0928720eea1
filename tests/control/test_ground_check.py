"""When the map is wrong: the ground check from commanded against measured motion."""

from __future__ import annotations

import math

import pytest

from helixd.base.geometry import BodyVelocity
from helixd.base.plan import MotionMode
from helixd.control.ground_check import GroundCheck, GroundCheckParams, GroundVerdict

DT = 0.02
SPEED = 0.6
AS_SHIPPED = (MotionMode.ROLL, MotionMode.SCROLL)  # the policy's modes for hard, mud


def roll(check: GroundCheck, fraction: float, metres: float) -> tuple[float, object]:
    """Roll at SPEED for ``metres`` of commanded travel on ground delivering ``fraction``:
    (metres actually travelled when a verdict came, the verdict) or (travelled, None)."""
    travelled = 0.0
    steps = round(metres / (SPEED * DT))
    for _ in range(steps):
        v = check.update(
            MotionMode.ROLL,
            BodyVelocity(SPEED, 0.0, 0.0),
            BodyVelocity(SPEED * fraction, 0.0, 0.0),
            DT,
        )
        travelled += SPEED * fraction * DT
        if v is not None:
            return travelled, v
    return travelled, None


def test_hard_ground_as_mapped_changes_nothing() -> None:
    check = GroundCheck(GroundCheckParams(*AS_SHIPPED))
    _, verdict = roll(check, 0.95, 50.0)
    assert verdict is None


def test_mud_under_roll_is_noticed_within_two_metres_of_travel_and_answers_scroll() -> None:
    check = GroundCheck(GroundCheckParams(*AS_SHIPPED))
    roll(check, 0.95, 10.0)  # the bank as mapped
    travelled, verdict = roll(check, 0.3, 20.0)  # the mud the map does not show
    assert verdict is not None and verdict.soft and verdict.mode is MotionMode.SCROLL
    assert verdict.fraction < 0.6
    assert travelled < 2.0
    assert check.switched


def test_back_on_firm_ground_scrolling_answers_the_planned_roll() -> None:
    check = GroundCheck(GroundCheckParams(*AS_SHIPPED))
    roll(check, 0.3, 5.0)
    assert check.switched
    travelled, got = scroll(check, 0.45, 20.0)  # in scroll on hard ground
    assert got is not None and not got.soft and got.mode is MotionMode.ROLL
    assert 5.0 <= travelled < 5.5  # not before min_change_m travelled since the last change


def scroll(
    check: GroundCheck, fraction: float, metres: float, vetoed: bool = False, wobble: float = 0.0
) -> tuple[float, object]:
    """Scroll at SPEED for ``metres`` commanded on ground delivering ``fraction`` (± ``wobble``,
    a slow sway of the delivered speed): (metres travelled at the verdict, it) or (…, None)."""
    travelled = 0.0
    for k in range(round(metres / (SPEED * DT))):
        got = fraction + wobble * math.sin(k * DT * 0.7)
        v = check.update(
            MotionMode.SCROLL,
            BodyVelocity(0.0, SPEED, 0.0),
            BodyVelocity(0.0, SPEED * got, 0.0),
            DT,
            vetoed,
        )
        travelled += SPEED * got * DT
        if v is not None:
            return travelled, v
    return travelled, None


def test_scrolling_in_water_after_a_soft_verdict_does_not_flip_back_to_roll() -> None:
    """Scrolling in water delivers about 0.6: a window dipping just under 0.55 is not firm
    ground (hysteresis), however far it goes."""
    check = GroundCheck(GroundCheckParams(*AS_SHIPPED))
    roll(check, 0.05, 5.0)  # a leg pinned to roll runs into the water
    assert check.switched
    _, verdict = scroll(check, 0.58, 60.0, wobble=0.05)  # dips to 0.53
    assert verdict is None
    assert check.switched


def test_no_change_of_mode_within_min_change_m_of_the_last() -> None:
    params = GroundCheckParams(*AS_SHIPPED, min_change_m=8.0)
    check = GroundCheck(params)
    roll(check, 0.3, 5.0)
    assert check.switched
    travelled, verdict = scroll(check, 0.3, 60.0)  # firm at once, but only 8 m on
    assert verdict is not None and not verdict.soft
    assert travelled >= 8.0
    travelled, verdict = roll(check, 0.3, 60.0)  # soft at once again: 8 m on as well
    assert verdict is not None and verdict.soft
    assert travelled >= 8.0


def test_never_firm_again_where_the_map_says_water() -> None:
    check = GroundCheck(GroundCheckParams(*AS_SHIPPED))
    roll(check, 0.05, 5.0)
    _, verdict = scroll(check, 0.3, 60.0, vetoed=True)  # delivering like hard ground
    assert verdict is None
    _, verdict = scroll(check, 0.3, 60.0, vetoed=False)  # past the map's water
    assert verdict is not None and verdict.mode is MotionMode.ROLL


def test_scrolling_as_planned_is_never_second_guessed() -> None:
    check = GroundCheck(GroundCheckParams(*AS_SHIPPED))
    for _ in range(2000):  # the map said water: scroll, whatever it delivers
        assert (
            check.update(
                MotionMode.SCROLL, BodyVelocity(0.0, SPEED, 0.0), BodyVelocity(0.0, 0.1, 0.0), DT
            )
            is None
        )


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_non_finite_input_is_no_verdict(bad: float) -> None:
    check = GroundCheck(GroundCheckParams(*AS_SHIPPED))
    for _ in range(500):
        assert (
            check.update(
                MotionMode.ROLL, BodyVelocity(SPEED, 0.0, 0.0), BodyVelocity(bad, 0.0, 0.0), DT
            )
            is None
        )
        assert (
            check.update(MotionMode.ROLL, BodyVelocity(SPEED, 0.0, 0.0), BodyVelocity.zero(), bad)
            is None
        )


def test_turns_in_place_and_stops_are_not_judged() -> None:
    check = GroundCheck(GroundCheckParams(*AS_SHIPPED))
    for _ in range(2000):  # turning in place: no translation commanded, none measured
        assert (
            check.update(MotionMode.ROLL, BodyVelocity(0.0, 0.0, 1.0), BodyVelocity.zero(), DT)
            is None
        )


def test_the_soft_mode_is_the_policys() -> None:
    """A policy that takes OMNI in mud: the check answers OMNI where rolling sinks."""
    check = GroundCheck(GroundCheckParams(MotionMode.ROLL, MotionMode.OMNI))
    _, verdict = roll(check, 0.3, 20.0)
    assert isinstance(verdict, GroundVerdict) and verdict.soft
    assert verdict.mode is MotionMode.OMNI and verdict.judged is MotionMode.ROLL


def test_a_policy_with_one_mode_for_firm_and_soft_ground_judges_nothing() -> None:
    """Rolling everywhere (mud: roll): there is no other mode to change to."""
    check = GroundCheck(GroundCheckParams(MotionMode.ROLL, MotionMode.ROLL))
    _, verdict = roll(check, 0.1, 20.0)
    assert verdict is None and not check.switched
