"""The ground fit: per medium and mode, the delivered fraction of a synthetic record whose
truth is known, its uncertainty, the energy per metre; rows straddling two media, gaps and
unsteady commands teach nothing; profiles merge weighted and fading."""

from __future__ import annotations

import math

import numpy as np
import pytest

from helixd.base.geometry import BodyVelocity
from helixd.base.media import MediaAreaNe, MediaMapNe, Medium
from helixd.base.plan import MotionMode
from helixd.config.vehicle import VehicleConfig
from helixd.control.ground_fit import (
    AxisSums,
    CellSums,
    Learned,
    Record,
    axis_fraction,
    identify,
    learned,
    merge_profiles,
)
from helixd.control.kinematics import body_to_fractions

VEHICLE = VehicleConfig()
DT = 0.02
# water north of 20 m, hard ground south of it
WATER_RING = ((20.0, -50.0), (20.0, 50.0), (90.0, 50.0), (90.0, -50.0))
WORLD = MediaMapNe((MediaAreaNe.build(Medium.WATER, WATER_RING, ()),), Medium.HARD)


def drive_north(
    mode: MotionMode,
    seconds: float,
    fractions: dict[Medium, float],
    speed: float = 0.5,
    noise_m: float = 0.0,
    seed: int = 1,
) -> Record:
    """A rover driving north at ``speed`` (no-slip command) in ``mode``, its ground delivering
    ``fractions[medium]`` of it (instantly: a steady command), position noise ``noise_m``."""
    rng = np.random.default_rng(seed)
    # facing so that the driving axis points North: ROLL yaw 0, SCROLL yaw +90° (body y left)
    yaw = 0.0 if mode is MotionMode.ROLL else math.pi / 2
    body = (
        BodyVelocity(speed, 0.0, 0.0) if mode is MotionMode.ROLL else BodyVelocity(0.0, speed, 0.0)
    )
    f = [float(x) for x in body_to_fractions(body, VEHICLE, mode)]
    t, n, e, y, s, m = [], [], [], [], [], []
    north = 0.0
    for i in range(round(seconds / DT)):
        t.append(i * DT)
        n.append(north + rng.normal(0.0, noise_m))
        e.append(rng.normal(0.0, noise_m))
        y.append(yaw)
        s.append(f)
        m.append(mode.value)
        medium = WORLD.medium_at(north, 0.0)
        north += speed * fractions[medium] * DT
    return Record(t, n, e, y, s, m)


def test_the_fit_finds_each_mediums_fraction_and_leaves_the_boundary_out() -> None:
    rec = drive_north(MotionMode.SCROLL, 180.0, {Medium.HARD: 0.3, Medium.WATER: 0.6})
    cells = identify(rec, WORLD, VEHICLE)
    assert set(cells) == {(Medium.HARD, MotionMode.SCROLL), (Medium.WATER, MotionMode.SCROLL)}
    hard = learned(cells[(Medium.HARD, MotionMode.SCROLL)], 1.0)
    water = learned(cells[(Medium.WATER, MotionMode.SCROLL)], 1.0)
    assert hard.fractions["scroll"] == pytest.approx(0.3, abs=0.01)
    assert water.fractions["scroll"] == pytest.approx(0.6, abs=0.01)
    assert hard.fractions["roll"] is None and hard.fractions["yaw"] is None  # not driven
    assert hard.metres == pytest.approx(20.0 - VEHICLE.ly_m, abs=0.5)  # up to the straddle
    # energy per metre: the same rpm, half the metres per second where half is delivered
    assert hard.power_w_per_mps == pytest.approx(2.0 * water.power_w_per_mps, rel=0.02)


def test_noise_widens_the_uncertainty_not_the_fraction() -> None:
    clean = identify(
        drive_north(MotionMode.ROLL, 60.0, {Medium.HARD: 0.8, Medium.WATER: 0.8}), WORLD, VEHICLE
    )
    noisy = identify(
        drive_north(MotionMode.ROLL, 60.0, {Medium.HARD: 0.8, Medium.WATER: 0.8}, noise_m=0.02),
        WORLD,
        VEHICLE,
    )
    key = (Medium.HARD, MotionMode.ROLL)
    a, b = learned(clean[key], 1.0), learned(noisy[key], 1.0)
    assert a.fractions["roll"] == pytest.approx(0.8, abs=0.005)
    assert b.fractions["roll"] == pytest.approx(0.8, abs=0.05)
    assert (a.sigmas["roll"] or 0.0) < (b.sigmas["roll"] or 0.0) < 0.05


def test_unsteady_commands_gaps_and_unknown_modes_teach_nothing() -> None:
    rec = drive_north(MotionMode.ROLL, 10.0, {Medium.HARD: 0.5, Medium.WATER: 0.5})
    wobbly = [[x * (1.0 + (i % 2)) for x in row] for i, row in enumerate(rec.scrolls)]
    cells = identify(
        Record(rec.t_s, rec.north_m, rec.east_m, rec.yaw_ned_rad, wobbly, rec.modes), WORLD, VEHICLE
    )
    assert cells[(Medium.HARD, MotionMode.ROLL)].roll.samples < 10  # of 500 rows
    sparse = Record(
        *(
            list(c)[::40]
            for c in (rec.t_s, rec.north_m, rec.east_m, rec.yaw_ned_rad, rec.scrolls, rec.modes)
        )
    )
    assert identify(sparse, WORLD, VEHICLE) == {}  # 0.8 s apart: every step a gap
    unknown = Record(
        rec.t_s, rec.north_m, rec.east_m, rec.yaw_ned_rad, rec.scrolls, [""] * len(rec.t_s)
    )
    assert identify(unknown, WORLD, VEHICLE) == {}
    with pytest.raises(ValueError, match="differ in length"):
        identify(
            Record(rec.t_s[:-1], rec.north_m, rec.east_m, rec.yaw_ned_rad, rec.scrolls, rec.modes),
            WORLD,
            VEHICLE,
        )


def test_profiles_merge_weighted_by_time_and_old_data_fades() -> None:
    old = CellSums(
        roll=AxisSums(10.0, 5.0, 2.6, 40.0, 2000), metres=10.0, energy_j=1000.0, runs=("a",)
    )
    new = CellSums(
        roll=AxisSums(10.0, 9.0, 8.2, 40.0, 2000), metres=10.0, energy_j=1000.0, runs=("b",)
    )
    key = (Medium.HARD, MotionMode.ROLL)
    even = merge_profiles({key: old}, {key: new}, 1.0)[key]
    assert even.roll.fraction == pytest.approx(0.7) and even.runs == ("a", "b")
    faded = merge_profiles({key: old}, {key: new}, 0.25)[key]
    assert faded.roll.fraction == pytest.approx((0.25 * 5.0 + 9.0) / (0.25 * 10.0 + 10.0))
    assert merge_profiles({key: old}, {}, 0.0)[key].roll.fraction is None  # forgotten
    many = CellSums(runs=tuple(f"r{i}" for i in range(250)))
    assert many.plus(new).runs == (*(f"r{i}" for i in range(51, 250)), "b")  # the newest 200
    with pytest.raises(ValueError, match="fade"):
        merge_profiles({}, {}, 1.5)


def test_too_little_taught_has_no_fraction_and_a_pin_wins() -> None:
    cell = CellSums(scroll=AxisSums(1.0, 0.5, 0.3, 3.0, 150))
    assert learned(cell, 5.0).fractions["scroll"] is None
    assert learned(cell, 2.0).fractions["scroll"] == pytest.approx(0.5)
    pinned = learned(cell, 5.0, {"scroll": 0.7})
    assert pinned.fractions["scroll"] == 0.7 and pinned.sigmas["scroll"] == 0.0
    assert pinned.pinned == ("scroll",)


def test_an_axis_is_read_from_the_mode_that_drives_it() -> None:
    def view(roll: float | None, scroll: float | None) -> Learned:
        return Learned({"roll": roll, "scroll": scroll, "yaw": None}, {}, {"yaw": 0}, 0.0, None, ())

    profile = {
        (Medium.MUD, MotionMode.ROLL): view(0.3, None),
        (Medium.MUD, MotionMode.SCROLL): view(None, 0.85),
        (Medium.SAND, MotionMode.OMNI): view(0.5, 0.2),
    }
    assert axis_fraction(profile, Medium.MUD, "roll") == 0.3
    assert axis_fraction(profile, Medium.MUD, "scroll") == 0.85
    assert axis_fraction(profile, Medium.SAND, "scroll") == 0.2  # from OMNI
    assert axis_fraction(profile, Medium.WATER, "roll") is None
