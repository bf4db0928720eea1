"""What the rover learnt plans the next flight: each leg carries the ground it crosses (for the
time estimate), the learned policy reads the profile, the profile file's problems are named."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.base.media import MediaAreaNe, MediaFrame, MediaMap, MediaMapNe, Medium
from helixd.base.plan import MissionFrameKind, MotionMode, Plan, PlanWaypoint
from helixd.config.root import HelixdConfig
from helixd.control.estimate import estimate_time
from helixd.control.ground_fit import Learned
from helixd.control.slip import SlipEstimator
from helixd.planning.media_modes import config_modes
from helixd.prepare.ground_learning import (
    OverMedia,
    learn_from_run,
    profile_path,
    slip_priors,
    with_learned_ground,
)

CFG = HelixdConfig()
MUD = ((10.0, -50.0), (10.0, 50.0), (40.0, 50.0), (40.0, -50.0))  # north 10..40 m
WORLD = MediaMapNe((MediaAreaNe.build(Medium.MUD, MUD, ()),), Medium.HARD)


def view(medium: Medium, mode: MotionMode, **fractions: float) -> dict:
    full = {"roll": None, "scroll": None, "yaw": None, **fractions}
    return {(medium, mode): Learned(full, {}, {a: 100 for a in full}, 10.0, None, ())}


def test_each_leg_carries_the_harmonic_mean_of_what_its_media_deliver() -> None:
    # x east, y north (ENU mission frame); one scroll leg 50 m north: 10 hard, 30 mud, 10 hard
    plan = Plan(
        "p", MotionMode.SCROLL, MissionFrameKind.LOCAL_NED, (PlanWaypoint(0.0, 50.0, 1.0),), 0.6
    )
    to_ne = lambda x, y: (y, x)  # noqa: E731
    learnt = {
        **view(Medium.MUD, MotionMode.SCROLL, scroll=0.3),
        **view(Medium.HARD, MotionMode.SCROLL, scroll=0.6),
    }
    got = with_learned_ground(plan, OverMedia(WORLD, to_ne, (0.0, 0.0)), learnt, CFG)
    (leg,) = got.waypoints
    assert leg.ground is not None
    # 20 m of hard ground (0.6: all of the command with the 2x feed-forward), 30 m of mud (0.3:
    # 0.6 of it): 70 m-equivalents for 50 m, delivered 5/7, the raw fraction half of it (the
    # rover's length blends the two at each boundary: a little faster)
    assert leg.ground[1] == pytest.approx(5.0 / 7.0 / 2.0, rel=0.03)
    assert leg.ground[1] > 5.0 / 7.0 / 2.0
    # unknown: the sourced table, not "no slip": roll hard 0.95, mud 0.3 (0.6 delivered with
    # the 2x feed-forward); yaw hard 0.85, mud 0.55 (both made up: all delivered)
    assert 0.3 < leg.ground[0] < 0.95 and leg.ground[2] == 1.0
    # a ground the operator declared stands where the profile knows nothing (roll 0.4: 0.8
    # delivered with the feed-forward everywhere; yaw 1: all of it)
    declared = HelixdConfig.model_validate({"control": {"slip": {"ground_roll_fraction": 0.4}}})
    over = OverMedia(WORLD, to_ne, (0.0, 0.0))
    (own,) = with_learned_ground(plan, over, learnt, declared).waypoints
    assert own.ground is not None
    assert own.ground[0] == pytest.approx(0.4) and own.ground[2] == 1.0
    assert own.ground[1] == pytest.approx(leg.ground[1])  # what the profile knows wins
    slow = estimate_time(got, CFG.control, (0.0, 0.0), None).driving_s
    fast = estimate_time(plan, CFG.control, (0.0, 0.0), None).driving_s
    assert slow == pytest.approx(1.4 * fast, rel=0.05)  # the cruise part 7/5 longer


def test_the_policy_defaults_and_the_profile_path(tmp_path: Path) -> None:
    learned = HelixdConfig.model_validate({"media": {"modes": "learned"}})
    assert config_modes(learned.media) == config_modes(CFG.media)
    assert profile_path(CFG) == Path("runs/ground-profile.yaml")
    own = HelixdConfig.model_validate({"ground": {"profile_file": str(tmp_path / "g.yaml")}})
    assert profile_path(own) == tmp_path / "g.yaml"


def test_learning_without_a_map_or_a_record_learns_nothing(tmp_path: Path) -> None:
    assert learn_from_run(CFG, None, tmp_path) is False
    own = HelixdConfig.model_validate({"ground": {"profile_file": str(tmp_path / "g.yaml")}})
    empty = MediaMap(MediaFrame.LOCAL_NED, (), Medium.HARD)
    assert learn_from_run(own, empty, tmp_path) is False  # no flight.csv: a warning, no raise
    assert not (tmp_path / "g.yaml").exists()


def test_the_slip_estimate_starts_from_where_each_mode_is_first_flown() -> None:
    # roll 5 m on hard ground, then scroll from north 15 m (in the mud) to 35 m
    wps = (
        PlanWaypoint(0.0, 5.0, 1.0, mode=MotionMode.ROLL),
        PlanWaypoint(0.0, 15.0, 1.0, mode=MotionMode.ROLL),
        PlanWaypoint(0.0, 35.0, 1.0, mode=MotionMode.SCROLL),
    )
    plan = Plan("p", MotionMode.ROLL, MissionFrameKind.LOCAL_NED, wps, 0.6)
    learnt = {
        **view(Medium.HARD, MotionMode.ROLL, roll=0.8, yaw=0.7),
        **view(Medium.MUD, MotionMode.SCROLL, scroll=0.4),
    }
    priors = dict(slip_priors(plan, OverMedia(WORLD, lambda x, y: (y, x), (0.0, 0.0)), learnt, CFG))
    assert priors[MotionMode.ROLL] == (0.8, 1.0, 0.7)  # hard ground; scroll unknown there
    assert priors[MotionMode.SCROLL] == (1.0, 0.4, 1.0)  # the mud at north 15 m
    estimator = SlipEstimator(CFG.control.slip, priors)
    assert estimator.estimate(MotionMode.SCROLL).vy_frac == pytest.approx(0.4)
    assert estimator.estimate(MotionMode.OMNI).vy_frac == 1.0  # not planned: declared
