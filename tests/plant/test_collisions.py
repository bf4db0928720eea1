"""Simulated obstacles: the rover stops against them and the simulator logs the contact."""

from __future__ import annotations

import math
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import ValidationError

from helixd.plant.collisions import SimObstacles, constrain, distance_m
from helixd.plant.plant_config import PlantConfig
from helixd.plant.state import PhysicsState
from tests.support.simcore import assert_step_never_closer, make_core, run, skid_north_contacts

POND: dict[str, Any] = {
    "circles": [{"north_m": 3.0, "east_m": 0.0, "radius_m": 1.0}],
    "polygons_ne_m": [[[10, -2], [10, 2], [12, 2], [12, -2]]],
}


def test_distance_to_circles_and_polygons() -> None:
    obs = SimObstacles.model_validate(POND)
    assert distance_m(obs, 0.0, 0.0) == pytest.approx(2.0)
    assert distance_m(obs, 3.0, 0.5) == 0.0
    assert distance_m(obs, 11.0, 0.0) == 0.0  # inside the polygon
    assert distance_m(obs, 11.0, 5.0) == pytest.approx(3.0)
    assert distance_m(SimObstacles(), 1.0, 1.0) == math.inf


def test_driving_into_a_circle_stops_at_the_body_radius_and_logs_one_contact() -> None:
    core = make_core(1, plant="sitl_skid", obstacles=POND)
    contacts = skid_north_contacts(core, 8.0)
    assert len(contacts) == 1
    # stopped before the body (0.429 m) reaches the disc's edge at north 2.0 m
    assert 1.5 < core.phys.north_m <= 2.0 - 0.429 + 1e-9
    assert core.phys.speed_mps == 0.0
    assert abs(core.phys.east_m) < 0.05
    core.set_rc(1, 1300)  # reverse: it may leave
    core.set_rc(3, 1300)
    run(core, 3.0)
    assert core.phys.north_m < 1.0
    assert [e.kind for e in core.drain_events() if e.kind.startswith("contact")] == ["contact_end"]


def test_no_obstacles_no_change() -> None:
    before = PhysicsState(north_m=0.0)
    after = PhysicsState(north_m=0.1, vx_body_mps=0.5)
    assert constrain(SimObstacles(), before, after) == (after, False)


@settings(max_examples=300, deadline=None)
@given(st.floats(-5, 15), st.floats(-5, 5), st.floats(-0.3, 0.3), st.floats(-0.3, 0.3))
def test_a_step_never_brings_the_body_closer_once_touching(
    n: float, e: float, dn: float, de: float
) -> None:
    assert_step_never_closer(SimObstacles.model_validate(POND), n, e, dn, de)


def test_bad_obstacles_are_refused() -> None:
    with pytest.raises(ValidationError, match="polygon 0: needs at least 3"):
        PlantConfig.model_validate({"obstacles": {"polygons_ne_m": [[[0, 0], [1, 1]]]}})
    with pytest.raises(ValidationError, match="finite number"):
        PlantConfig.model_validate(
            {"obstacles": {"polygons_ne_m": [[[0, 0], [1, float("nan")], [2, 0]]]}}
        )
    with pytest.raises(ValidationError):
        PlantConfig.model_validate(
            {"obstacles": {"circles": [{"north_m": 0, "east_m": 0, "radius_m": -1}]}}
        )
    with pytest.raises(ValidationError):
        PlantConfig.model_validate({"obstacles": {"walls": []}})
