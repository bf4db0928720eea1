"""The mode follows the medium: stretches, transitions on the firm side, via stops."""

from __future__ import annotations

import math

import pytest

from helixd.base.frames import MissionFrame
from helixd.base.media import MediaArea, MediaFrame, MediaMap, MediaMapNe, Medium
from helixd.base.plan import MissionFrameKind, MotionMode, Plan, PlanWaypoint
from helixd.config.media import MediaConfig
from helixd.planning.media_modes import ModePolicy, config_modes, follow_media

ENU = MissionFrame.enu().to_ned
DEFAULTS = config_modes(MediaConfig())  # media.modes as the config ships it
POLICY = ModePolicy.from_config(MediaConfig(transition_margin_m=1.0, min_stretch_m=5.0))


def strip(medium: Medium, north0: float, north1: float) -> MediaArea:
    """A band across the map from north0 to north1 (east −100..100)."""
    ring = ((north0, -100.0), (north0, 100.0), (north1, 100.0), (north1, -100.0))
    return MediaArea(medium, ring)


def pond(*areas: MediaArea) -> MediaMapNe:
    return MediaMap(MediaFrame.LOCAL_NED, areas, Medium.HARD).to_ne()


def plan_of(*xy: tuple[float, float], mode: MotionMode = MotionMode.ROLL) -> Plan:
    wps = tuple(PlanWaypoint(x, y, 0.5) for x, y in xy)
    return Plan("t", mode, MissionFrameKind.LOCAL_NED, wps, 0.5)


def test_a_crossing_rolls_to_the_bank_turns_there_and_scrolls_across() -> None:
    # bank 0..10 m north, water 10..50, bank beyond; one leg from (0, 0) to (0, 60) (x east)
    media = pond(strip(Medium.WATER, 10.0, 50.0))
    got = follow_media(plan_of((0.0, 60.0)), media, POLICY, (0.0, 0.0), ENU)
    wps = got.plan.waypoints
    assert [(round(w.y_m, 6), w.mode, w.via, w.stop) for w in wps] == [
        (9.0, MotionMode.ROLL, True, True),  # a metre before the water, on the bank
        (51.0, MotionMode.SCROLL, True, True),  # a metre onto the far bank
        (60.0, MotionMode.ROLL, False, False),
    ]
    assert [w.media_stop for w in wps] == [True, True, False]
    assert [(t.before, t.after, t.medium) for t in got.transitions] == [
        (MotionMode.ROLL, MotionMode.SCROLL, Medium.HARD),
        (MotionMode.SCROLL, MotionMode.ROLL, Medium.HARD),
    ]
    assert all(math.isclose(t.turn_rad, math.pi / 2) for t in got.transitions)
    assert [(s.mode, s.main_medium) for s in got.stretches] == [
        (MotionMode.ROLL, Medium.HARD),
        (MotionMode.SCROLL, Medium.WATER),
        (MotionMode.ROLL, Medium.HARD),
    ]
    assert math.isclose(sum(s.length_m for s in got.stretches), 60.0)


def test_one_medium_changes_nothing_but_the_modes() -> None:
    plan = plan_of((0.0, 10.0), (10.0, 10.0))
    got = follow_media(plan, pond(), POLICY, (0.0, 0.0), ENU)
    assert [(w.x_m, w.y_m, w.stop, w.via) for w in got.plan.waypoints] == [
        (0.0, 10.0, False, False),
        (10.0, 10.0, False, False),
    ]
    assert got.transitions == ()
    assert got.plan.single_mode


def test_a_mode_change_at_a_waypoint_makes_it_the_stop() -> None:
    # the water starts 0.02 m past waypoint 1's place... no: exactly a margin before it
    media = pond(strip(Medium.WATER, 11.0, 40.0))
    got = follow_media(plan_of((0.0, 10.0), (0.0, 30.0)), media, POLICY, (0.0, 0.0), ENU)
    wps = got.plan.waypoints
    assert len(wps) == 2  # the transition (11 − 1 = 10 m) falls on waypoint 1: no via
    assert wps[0].stop and wps[0].mode is MotionMode.ROLL and not wps[0].via
    assert wps[1].mode is MotionMode.SCROLL


def test_a_short_strip_of_hard_ground_in_water_is_not_worth_two_turns() -> None:
    media = pond(strip(Medium.WATER, 0.0, 20.0), strip(Medium.HARD, 10.0, 11.0))
    got = follow_media(plan_of((0.0, 19.0)), media, POLICY, (0.0, 1.0), ENU)
    assert got.transitions == ()
    assert [w.mode for w in got.plan.waypoints] == [MotionMode.SCROLL]


def test_a_short_mud_strip_on_the_bank_is_scrolled_not_rolled() -> None:
    media = pond(strip(Medium.MUD, 5.0, 5.8))
    got = follow_media(plan_of((0.0, 20.0)), media, POLICY, (0.0, 0.0), ENU)
    modes = [got.plan.mode_at(i) for i in range(len(got.plan.waypoints))]
    assert MotionMode.SCROLL in modes  # the mud is crossed in SCROLL, never rolled


def test_a_waypoints_own_mode_pins_its_leg() -> None:
    media = pond(strip(Medium.WATER, 10.0, 50.0))
    plan = plan_of((0.0, 60.0))
    pinned = Plan(
        plan.name, plan.mode, plan.frame,
        (PlanWaypoint(0.0, 60.0, 0.5, mode=MotionMode.SCROLL),), plan.speed_mps,
    )  # fmt: skip
    got = follow_media(pinned, media, POLICY, (0.0, 0.0), ENU)
    assert [w.mode for w in got.plan.waypoints] == [MotionMode.SCROLL]
    assert got.transitions == ()


def test_the_mission_policy_replaces_the_default() -> None:
    media = pond(strip(Medium.WATER, 10.0, 50.0))
    omni = ModePolicy({**DEFAULTS, Medium.WATER: MotionMode.OMNI}, margin_m=1.0)
    got = follow_media(plan_of((0.0, 60.0)), media, omni, (0.0, 0.0), ENU)
    assert [t.after for t in got.transitions] == [MotionMode.OMNI, MotionMode.ROLL]
    assert [t.turn_rad for t in got.transitions] == [0.0, 0.0]


def test_a_leg_pinned_to_roll_carries_where_the_map_says_it_cannot_roll() -> None:
    # water 10..30 m north of a 40 m leg pinned to roll; the plan's other legs carry nothing
    media = pond(strip(Medium.MUD, 10.0, 12.0), strip(Medium.WATER, 12.0, 30.0))
    wps = (PlanWaypoint(0.0, 40.0, 0.5, mode=MotionMode.ROLL), PlanWaypoint(10.0, 40.0, 0.5))
    plan = Plan("t", MotionMode.ROLL, MissionFrameKind.LOCAL_NED, wps, 0.5)
    got = follow_media(plan, media, POLICY, (0.0, 0.0), ENU)
    pinned, after = got.plan.waypoints
    spans = [(round(a, 6), round(b, 6)) for a, b in pinned.unfit_to_go_m]
    assert spans == [(10.0, 30.0)]  # mud and water, 10..30 m still to go, nearest first
    assert after.unfit_to_go_m == ()


def test_a_pinned_leg_beside_a_stretch_in_its_own_mode_adds_no_stop() -> None:
    wps = (PlanWaypoint(0.0, 40.0, 0.5, mode=MotionMode.ROLL), PlanWaypoint(10.0, 40.0, 0.5))
    plan = Plan("t", MotionMode.ROLL, MissionFrameKind.LOCAL_NED, wps, 0.5)
    got = follow_media(plan, pond(strip(Medium.WATER, 10.0, 30.0)), POLICY, (0.0, 0.0), ENU)
    assert [(w.x_m, w.y_m, w.via, w.stop) for w in got.plan.waypoints] == [
        (0.0, 40.0, False, False),
        (10.0, 40.0, False, False),
    ]
    assert got.transitions == ()


def test_the_policy_comes_from_the_config_the_learned_picks_and_the_mission() -> None:
    """One source: the config's media.modes (its defaults as shipped), or the ground
    profile's learned picks in their place, a mission's media_modes over either."""
    media = MediaConfig.model_validate({"modes": {"sand": "scroll"}, "transition_margin_m": 2.0})
    policy = ModePolicy.from_config(media)
    assert policy.mode_for(Medium.SAND) is MotionMode.SCROLL
    assert policy.mode_for(Medium.HARD) is MotionMode.ROLL  # the config's default
    assert (policy.margin_m, policy.min_stretch_m) == (2.0, media.min_stretch_m)
    mission = {Medium.WATER: MotionMode.OMNI}
    assert ModePolicy.from_config(media, mission).mode_for(Medium.WATER) is MotionMode.OMNI
    learned = {**DEFAULTS, Medium.MUD: MotionMode.ROLL}
    from_profile = ModePolicy.from_config(MediaConfig(modes="learned"), mission, learned)
    assert from_profile.mode_for(Medium.MUD) is MotionMode.ROLL
    assert from_profile.mode_for(Medium.WATER) is MotionMode.OMNI  # the mission's still wins
    assert ModePolicy.from_config(MediaConfig(modes="learned")).modes == DEFAULTS


def test_a_policy_without_a_medium_is_refused_not_guessed() -> None:
    """No silent SCROLL for a medium the policy was not given."""
    partial = {m: mode for m, mode in DEFAULTS.items() if m is not Medium.GRASS}
    with pytest.raises(ValueError, match="no mode for grass"):
        ModePolicy(partial)
