"""The speed cap per medium and mode (helixd.control.ground_cap): its numbers, a leg's cap
over the media it crosses, and the navigator and the time estimate flying a capped leg."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from helixd.base.geometry import Pose2D
from helixd.base.media import Medium
from helixd.base.plan import MissionFrameKind, MotionMode, Plan, PlanWaypoint
from helixd.config.root import HelixdConfig
from helixd.config.vehicle import VehicleConfig
from helixd.control.estimate import estimate_time
from helixd.control.ground_cap import (
    capped_leg_speeds_mps,
    full_speed_mps,
    leg_cap_mps,
    speed_cap_mps,
)
from helixd.control.navigator import Navigator
from tests.support.ideal_plant import IdealPlant

CFG = HelixdConfig()
SLIP = CFG.control.slip  # max_gain 2, stuck_fraction 0.15
V_FULL = 0.175 * 195.0 * 2.0 * math.pi / 60.0 * 0.9  # r · ω_max · output_clamp ≈ 3.216 m/s


def test_full_speed_is_the_scrolls_at_their_clamp_without_slip() -> None:
    assert full_speed_mps(VehicleConfig()) == pytest.approx(V_FULL)
    assert pytest.approx(3.2162, abs=1e-4) == V_FULL


@pytest.mark.parametrize(
    ("fraction", "cap"),
    [
        (0.6, 0.9 * 0.6 * V_FULL),  # the feed-forward makes it up: margin · f · v_full (1.737)
        (1.0, 0.9 * V_FULL),  # no slip: margin · v_full
        (0.3, 0.9 * V_FULL / 2.0),  # the gain capped at 2: the scrolls at 2 · v (1.447)
        (0.1, 0.9 * V_FULL),  # a stall: not amplified, v itself is the demand
    ],
)
def test_the_cap_keeps_the_scrolls_demand_within_the_margin(fraction: float, cap: float) -> None:
    got = speed_cap_mps(fraction, V_FULL, 0.9, SLIP)
    assert got == pytest.approx(cap)
    demand = got * min(SLIP.max_gain, 1.0 / fraction) if fraction >= 0.15 else got
    assert demand == pytest.approx(0.9 * V_FULL)  # exactly the margin of full speed


def test_a_fraction_that_says_nothing_sets_no_cap() -> None:
    assert speed_cap_mps(0.0, V_FULL, 0.9, SLIP) is None
    assert speed_cap_mps(math.nan, V_FULL, 0.9, SLIP) is None


def test_without_the_feed_forward_the_cap_is_the_margin_of_what_the_ground_delivers() -> None:
    off = SLIP.model_copy(update={"enabled": False})
    assert speed_cap_mps(0.3, V_FULL, 0.9, off) == pytest.approx(0.9 * V_FULL)


def test_a_leg_takes_the_lowest_cap_of_the_media_it_crosses_on_its_driven_axes() -> None:
    known = {
        (Medium.HARD, "roll"): 0.95,
        (Medium.MUD, "roll"): 0.6,
        (Medium.MUD, "scroll"): 0.55,
        (Medium.WATER, "scroll"): 0.7,
    }

    def fraction_of(medium: Medium, axis: str) -> float | None:
        return known.get((medium, axis))

    both = [Medium.HARD, Medium.MUD]
    roll = leg_cap_mps(both, MotionMode.ROLL, fraction_of, V_FULL, 0.5, SLIP)
    assert roll == pytest.approx(0.5 * 0.6 * V_FULL)  # the mud's roll, not the hard ground's
    omni = leg_cap_mps(both, MotionMode.OMNI, fraction_of, V_FULL, 0.5, SLIP)
    assert omni == pytest.approx(0.5 * 0.55 * V_FULL)  # OMNI: the lower of its two axes
    # SCROLL over hard ground the profile does not know in SCROLL: only the mud caps it
    scroll = leg_cap_mps(both, MotionMode.SCROLL, fraction_of, V_FULL, 0.5, SLIP)
    assert scroll == pytest.approx(0.5 * 0.55 * V_FULL)
    assert leg_cap_mps([Medium.GRASS], MotionMode.ROLL, fraction_of, V_FULL, 0.5, SLIP) is None


def capped_line(cap_mps: float | None) -> Plan:
    wps = (PlanWaypoint(20.0, 0.0, 0.2, speed_cap_mps=cap_mps), PlanWaypoint(40.0, 0.0, 0.2))
    return Plan("capped", MotionMode.ROLL, MissionFrameKind.START, wps, 0.6)


def test_the_navigator_never_commands_more_than_the_legs_cap_and_the_estimate_agrees() -> None:
    """Two 20 m legs at 0.6 m/s cruise, the first capped at 0.25 m/s: the navigator's speed
    command stays at or under 0.25 m/s on it and reaches 0.6 m/s on the second; the estimate
    flies the same cruise (20 m at 0.25 m/s: 80 s instead of 33 s) and the same time."""
    plan = capped_line(0.25)
    assert capped_leg_speeds_mps(plan) == [0.25, 0.6]
    nav = Navigator(plan, CFG.control)
    plant = IdealPlant(Pose2D(0.0, 0.0, 0.0), plan.mode, VehicleConfig())
    peak = [0.0, 0.0]
    for _ in range(100_000):
        out = nav.step(plant.pose, plant.t_s)
        if out.done:
            break
        leg = nav.target_index  # the leg being flown (its waypoint passed within tolerance)
        peak[leg] = max(peak[leg], math.hypot(out.command.vx_mps, out.command.vy_mps))
        plant.step(out.command, 0.025)
    else:
        raise AssertionError("the navigator never finished")
    assert peak[0] <= 0.25 + 1e-9
    assert peak[0] == pytest.approx(0.25, abs=0.01)  # it does fly at the cap
    assert peak[1] == pytest.approx(0.6, abs=0.01)
    est = estimate_time(plan, CFG.control, (0.0, 0.0), 0.0).total_s
    uncapped = estimate_time(capped_line(None), CFG.control, (0.0, 0.0), 0.0).total_s
    assert est == pytest.approx(plant.t_s, rel=0.03)
    assert est - uncapped == pytest.approx(20.0 / 0.25 - 20.0 / 0.6, rel=0.1)


def test_a_cap_above_the_cruise_changes_nothing() -> None:
    plan = capped_line(0.9)
    assert capped_leg_speeds_mps(plan) == [0.6, 0.6]
    free = replace(plan, waypoints=tuple(replace(w, speed_cap_mps=None) for w in plan.waypoints))
    same = estimate_time(free, CFG.control, (0.0, 0.0), 0.0).total_s
    assert estimate_time(plan, CFG.control, (0.0, 0.0), 0.0).total_s == pytest.approx(same)
