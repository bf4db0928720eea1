"""--show-plan's plan → lat/lon items (pure) and --mission autopilot's conversion of what the
autopilot holds (refusals name the item, exit 3)."""

from __future__ import annotations

import asyncio
import math
from types import SimpleNamespace
from typing import Any

import pytest
import typer
from hypothesis import given
from hypothesis import strategies as hs

from helixd.base.exitcodes import ExitCode
from helixd.base.frames import NedPose, latlon_to_ne
from helixd.base.plan import MissionFrameKind, MotionMode, Plan, PlanWaypoint
from helixd.cli.autopilot import convert, wants_autopilot
from helixd.config.root import HelixdConfig
from helixd.mav.mission_item import MissionItem
from helixd.mission.formats.items import GcsMission
from helixd.mission.formats.wire import gcs_to_wire
from helixd.mission.judge import mission_vs_config
from helixd.runtime.show_plan import plan_as_gcs, show_plan

ORIGIN = (53.5233, -113.5263)
CFG = HelixdConfig()


def square(frame: MissionFrameKind) -> Plan:
    pts = [(10.0, 0.0), (10.0, 10.0), (0.0, 10.0), (0.0, 0.0)]
    wps = tuple(PlanWaypoint(x, y, 0.3) for x, y in pts)
    return Plan("sq", MotionMode.ROLL, frame, wps, 0.6)


def ne_of(gcs: GcsMission) -> list[tuple[float, float]]:
    return [latlon_to_ne(it.x, it.y, *ORIGIN) for it in gcs.items]


def test_start_frame_plan_lands_where_the_rover_flies_it() -> None:
    # rover at N 5, E 2 facing east (yaw 90°): x forward = east, y left = north
    start = NedPose(5.0, 2.0, math.pi / 2)
    gcs = plan_as_gcs(square(MissionFrameKind.START), start, ORIGIN)
    expected = [(5.0, 12.0), (15.0, 12.0), (15.0, 2.0), (5.0, 2.0)]
    for (n, e), (en, ee) in zip(ne_of(gcs), expected, strict=True):
        assert n == pytest.approx(en, abs=1e-3) and e == pytest.approx(ee, abs=1e-3)
    assert [it.command for it in gcs.items] == [16] * 4
    assert [it.seq for it in gcs.items] == [1, 2, 3, 4]
    home_n, home_e = latlon_to_ne(*gcs.home_latlon_deg, *ORIGIN)  # type: ignore[misc]
    assert (home_n, home_e) == pytest.approx((5.0, 2.0), abs=1e-3)


def test_enu_plan_is_x_east_y_north_from_the_origin() -> None:
    gcs = plan_as_gcs(square(MissionFrameKind.LOCAL_NED), NedPose(0.0, 0.0, 0.0), ORIGIN)
    assert ne_of(gcs)[0] == pytest.approx((0.0, 10.0), abs=1e-3)  # x 10 → east 10


@given(hs.floats(-1e3, 1e3), hs.floats(-1e3, 1e3), hs.floats(-4.0, 4.0))
def test_items_always_encode_for_the_wire(n: float, e: float, yaw: float) -> None:
    gcs = plan_as_gcs(square(MissionFrameKind.START), NedPose(n, e, yaw), ORIGIN)
    wire = gcs_to_wire(gcs)
    assert len(wire.mission) == 5 and wire.fence == ()


def test_non_finite_start_is_an_error_not_a_plan() -> None:
    with pytest.raises(ValueError):
        plan_as_gcs(square(MissionFrameKind.START), NedPose(math.nan, 0.0, 0.0), ORIGIN)


def test_show_plan_uploads_nothing_in_auto() -> None:
    sent: list[Any] = []
    ap: Any = SimpleNamespace(state=SimpleNamespace(mode="AUTO"), send_message=sent.append)
    plan = square(MissionFrameKind.START)
    warning = asyncio.run(show_plan(ap, plan, NedPose(0.0, 0.0, 0.0), ORIGIN, 1.0))
    assert warning is not None and "AUTO" in warning and sent == []


def wire_wp(seq: int, lat: float, lon: float, command: int = 16) -> MissionItem:
    return MissionItem(seq=seq, frame=3, command=command, x=lat, y=lon)


HOME = wire_wp(0, *ORIGIN)


def test_convert_flies_the_waypoints_with_the_given_mode() -> None:
    got = convert(
        (HOME, wire_wp(1, 53.5234, -113.5263), wire_wp(2, 53.5234, -113.5262)),
        (),
        source="autopilot at X",
        cfg=CFG,
        mode=MotionMode.OMNI,
    )
    assert got.mission.frame is MissionFrameKind.GLOBAL and got.mission.mode is MotionMode.OMNI
    assert len(got.mission.waypoints) == 2 and got.items == 2


def refusal(mission: tuple[MissionItem, ...], capsys: pytest.CaptureFixture[str]) -> list[str]:
    with pytest.raises(typer.Exit) as info:
        convert(mission, (), source="autopilot at X", cfg=CFG, mode=MotionMode.ROLL)
    assert info.value.exit_code == ExitCode.PREFLIGHT
    return [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("error:")]


def test_empty_mission_refused(capsys: pytest.CaptureFixture[str]) -> None:
    (line,) = refusal((HOME,), capsys)
    assert "autopilot at X" in line and "no mission" in line


def test_unsupported_item_named(capsys: pytest.CaptureFixture[str]) -> None:
    """A waypoint off the Earth is refused by the conversion, naming the item; what helixd
    cannot fly (NAV_GUIDED_ENABLE) is kept by it and refused by the mission check."""
    bad = MissionItem(seq=2, frame=3, command=16, x=95.0, y=0.0)
    (line,) = refusal((HOME, wire_wp(1, 53.5234, -113.5263), bad), capsys)
    assert "autopilot mission item 2" in line and "off the Earth" in line
    mission = (HOME, wire_wp(1, 53.5234, -113.5263), wire_wp(2, 53.5234, -113.5262, 92))
    got = convert(mission, (), source="autopilot at X", cfg=CFG, mode=MotionMode.ROLL)
    problems: list[str] = []
    mission_vs_config(CFG, got.mission, "autopilot at X", problems)
    assert any("item 2 NAV_GUIDED_ENABLE" in p and "skip-unsupported" in p for p in problems)


def test_no_mode_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(typer.Exit) as info:
        convert((HOME,), (), source="s", cfg=CFG, mode=None)
    assert info.value.exit_code == ExitCode.USAGE
    assert "--mode" in capsys.readouterr().err


def test_only_the_bare_word_means_the_autopilot() -> None:
    from pathlib import Path

    assert wants_autopilot(Path("autopilot"))
    assert not wants_autopilot(Path("./autopilot.yaml"))
    assert not wants_autopilot(Path("missions/autopilot"))
