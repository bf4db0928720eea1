"""Smoke test of the benchmark tools' pure helpers (the benchmarks themselves are not tests)."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path
from types import ModuleType

import pytest
import yaml

TOOLS = Path(__file__).resolve().parents[2] / "tools"


def load_tool(name: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(f"bench_{name}", TOOLS / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


nav = load_tool("bench_navigation")
loop = load_tool("bench_control_loop")


# -- bench_navigation -------------------------------------------------------------------------


def test_all_nine_combinations_with_terrain_per_mode() -> None:
    combos = nav.select_combos([], nav.parse_terrains([]))
    assert len(combos) == 9
    assert {(c.mission, c.mode) for c in combos} == {
        (m, mode) for m in ("square", "hexagon", "circle") for mode in ("roll", "scroll", "omni")
    }
    assert {c.mode: c.terrain for c in combos} == {"roll": "hard", "scroll": "mud", "omni": "mud"}


def test_only_filters_and_terrain_override() -> None:
    terrains = nav.parse_terrains(["omni=grass"])
    picked = nav.select_combos(["square/roll", "omni", "square"], terrains)
    labels = [c.label for c in picked]
    assert labels == [
        "square/roll",
        "square/omni",
        "hexagon/omni",
        "circle/omni",
        "square/scroll",
    ]
    assert all(c.terrain == "grass" for c in picked if c.mode == "omni")
    with pytest.raises(ValueError, match="--only"):
        nav.select_combos(["triangle"], terrains)
    with pytest.raises(ValueError, match="MODE=TERRAIN"):
        nav.parse_terrains(["omni=ice"])


def test_mission_mode_is_replaced_and_shipped_missions_load() -> None:
    from helixd.mission import Mission

    text = (nav.MISSIONS_DIR / "hexagon.yaml").read_text(encoding="utf-8")
    changed = Mission.model_validate(yaml.safe_load(nav.mission_with_mode(text, "roll")))
    assert changed.mode.value == "roll"
    assert len(changed.waypoints) == 6


def test_autopilot_duration_from_flight_csv() -> None:
    csv = "# comment\nt_boot_s,t_mono_s,x\n32.080,1.0,0\n40.000,2.0,0\n101.960,3.0,0\n"
    assert nav.autopilot_duration_s(csv) == pytest.approx(69.88)
    assert nav.autopilot_duration_s("# c\nt_boot_s,t_mono_s\n1.0,2.0\n") is None


def test_failed_run_is_reported_with_its_fault() -> None:
    combo = nav.Combo("square", "omni", "mud")
    summary = {
        "completed": False,
        "fault": "stall: commanded 0.4 m/s, measured 0.0 m/s for 4 s",
        "waypoints_reached": 1,
        "waypoints_total": 4,
        "cross_track_rms_m": 0.5,
        "cross_track_max_m": 1.5,
        "final_error_m": None,
    }
    r = nav.result_from_summary(combo, 3, summary, 40.0, 12.0, 4, "")
    assert not r.completed and r.reached == 1
    row = nav.run_row(r)
    assert row[4] == "FAILED" and row[5] == "1/4" and row[8] == "-" and row[-1] == "4"
    (line,) = nav.failure_lines([r])
    assert "square/omni" in line and "stall" in line and "seed 3" in line
    ok = nav.result_from_summary(
        combo, 4, {**summary, "completed": True, "fault": None}, 1, 1, 0, ""
    )
    agg = nav.aggregate_rows([r, ok])
    assert agg == [("square", "omni", "mud", "1/2", "0.50/0.50", "1.50/1.50", "-", "20.5/40.0")]
    table = nav.format_table(nav.AGG_HEADERS, agg)
    assert table.splitlines()[0].startswith("mission") and "1/2" in table
    missing = nav.result_from_summary(combo, 5, None, None, 3.0, 3, "level=error boom")
    assert not missing.completed and "boom" in (missing.fault or "")


# -- bench_control_loop -----------------------------------------------------------------------


def test_percentiles_and_jitter() -> None:
    values = [float(i) for i in range(1, 101)]
    s = loop.stats(values)
    assert (s.n, s.p50, s.p99, s.max) == (100, 50.0, 99.0, 100.0)
    assert loop.stats([]) is None
    dev = loop.interval_deviations([0.0, 0.020, 0.041, 0.060], 0.020)
    assert dev == pytest.approx([0.0, 0.001, 0.001])


def test_latency_matching_and_autopilot_round_trip() -> None:
    sent = {100: 1.000, 120: 1.020}
    steps = [
        loop.Step(100, 1.0001, 1.0002, 1.0003, 1.0004),
        loop.Step(120, 1.0202, 1.0205, 1.0206, 1.0209),
        loop.Step(140, 2, 2, 2, 2),
    ]
    lat = loop.match_latencies(sent, steps)
    assert lat.unmatched == 1
    assert lat.total_s == pytest.approx([0.0004, 0.0009])
    assert lat.wire_s == pytest.approx([0.0001, 0.0002])
    assert lat.inside_s == pytest.approx([0.0003, 0.0007])
    assert lat.wake_s == pytest.approx([0.0001, 0.0003])
    assert lat.compute_s == pytest.approx([0.0001, 0.0001])
    assert lat.send_s == pytest.approx([0.0001, 0.0003])
    # the second pose got no answer before the third was sent
    rtt = loop.first_responses([1.0, 1.02, 1.04], [1.0005, 1.0006, 1.0410])
    assert rtt[1] is None
    assert [rtt[0], rtt[2]] == pytest.approx([0.0005, 0.001])


def test_fake_autopilot_plant_follows_overrides() -> None:
    """Full forward on the left pair, full reverse on the right pair drives ROLL forward."""
    ap = loop.FakeAutopilot(50.0, boot_s=0.0)
    ap.pwm_us[:4] = [1800, 1800, 1200, 1200]
    ap.advance(1.0)
    assert ap.north_m > 0.5 and math.isclose(ap.east_m, 0.0, abs_tol=1e-9)
    assert math.isclose(ap.yaw_ned_rad, 0.0, abs_tol=1e-9)
    ap.pwm_us[:4] = [1600] * 4  # all four the same way: turn in place (CCW → NED yaw falls)
    ap.advance(2.0)
    assert ap.yaw_ned_rad < 0.0


def test_square_laps() -> None:
    pts = loop.square_laps(20.0, 2)
    assert len(pts) == 8 and pts[3] == (0.0, 0.0) and pts[4] == (20.0, 0.0)
