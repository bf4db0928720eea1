"""Smoke test of the benchmark tools' pure helpers (the benchmarks themselves are not tests)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
import yaml

from helixd.base.frames import MissionFrame, NedPose
from tests.support.tools import load_tool

nav = load_tool("bench_navigation")
loop = load_tool("bench_control_loop")
res = load_tool("bench_results")


# -- bench_navigation -------------------------------------------------------------------------


def test_default_matrix_roll_on_hard_only() -> None:
    combos = nav.select_combos(
        [], nav.parse_terrains([]), nav.parse_guidances([]), False, nav.parse_noises([])
    )
    cells = {c.cell for c in combos}
    # noise low: 3 missions x (roll/hard, scroll/hard, scroll/mud, omni/hard, omni/mud);
    # noise thesis: the square's 5; plus the survey block (line law, sitl_skid plant)
    assert len(cells) == 15 + 5 + 1 and len(combos) == 3 * 20 + 1
    assert not any(c.mode == "roll" and c.terrain == "mud" for c in combos)
    assert {c.guidance for c in combos} == {"line", "thesis", "thesis-tight"}
    assert {c.mission for c in combos if c.noise == "thesis"} == {"square"}
    (survey,) = [c for c in combos if c.mission == "survey"]
    assert (survey.mode, survey.plant, survey.guidance, survey.noise) == (
        "roll", "sitl_skid", "line", "low",
    )  # fmt: skip
    anywhere = nav.select_combos([], ("hard", "mud"), ("thesis",), roll_anywhere=True)
    assert len(anywhere) == 18  # no survey without the line law
    with pytest.raises(ValueError, match="--noise"):
        nav.parse_noises(["loud"])


def test_only_filters_terrain_and_guidance_options() -> None:
    picked = nav.select_combos(["square/roll", "omni/mud", "circle/scroll/hard"], ("hard", "mud"))
    assert [c.label for c in picked] == [
        "square/roll/hard/low/thesis",
        "square/omni/mud/low/thesis",
        "hexagon/omni/mud/low/thesis",
        "circle/scroll/hard/low/thesis",
        "circle/omni/mud/low/thesis",
    ]
    assert [c.label for c in nav.select_combos(["mud", "hexagon/mud"], ("mud",))] == [
        "square/scroll/mud/low/thesis",
        "square/omni/mud/low/thesis",
        "hexagon/scroll/mud/low/thesis",
        "hexagon/omni/mud/low/thesis",
        "circle/scroll/mud/low/thesis",
        "circle/omni/mud/low/thesis",
    ]
    only_survey = nav.select_combos(["survey"], ("hard",), ("line", "thesis"))
    assert [c.label for c in only_survey] == ["survey/roll/hard/low/line"]
    with pytest.raises(ValueError, match="--only"):
        nav.select_combos(["triangle"], ("hard",))
    with pytest.raises(ValueError, match="--only"):
        nav.select_combos(["square/roll"], ("mud",))
    with pytest.raises(ValueError, match="--terrain"):
        nav.parse_terrains(["ice"])
    with pytest.raises(ValueError, match="--guidance"):
        nav.parse_guidances(["pure-pursuit"])
    assert nav.parse_guidances(["thesis", "thesis"]) == ("thesis",)


def test_guidance_goes_to_the_daemon_only_when_not_its_default() -> None:
    assert "control" not in nav.daemon_config("thesis", "thesis")
    assert nav.daemon_config("line", "thesis")["control"] == {"guidance": "line"}
    assert nav.daemon_config("thesis", "line")["control"] == {"guidance": "thesis"}
    assert nav.daemon_config("thesis-tight", "line")["control"] == {"guidance": "thesis"}
    default = nav.default_guidance()
    assert nav.guidance_refusal(default, default) is None
    # a law no daemon knows is refused with the config loader's own words
    why = nav.guidance_refusal("zigzag", default)
    assert why is not None and "control.guidance" in why


def test_skid_plant_runs_get_the_sitl_suite_config() -> None:
    from helixd.config.root import HelixdConfig

    skid = nav.daemon_config("line", "line", "sitl_skid")
    cfg = HelixdConfig.model_validate(skid)
    assert [ch.channel for ch in cfg.actuation.channels] == [3, 4, 1, 2]
    # the SITL suite's config: a normal arm (no force); the bench's own connect timeout
    assert not cfg.startup.force_arm and cfg.startup.connect_timeout_s == 20.0
    assert "actuation" not in nav.daemon_config("line", "line")


def test_mission_mode_is_replaced_and_shipped_missions_load() -> None:
    from helixd.mission.model import Mission

    text = (nav.MISSIONS_DIR / "hexagon.yaml").read_text(encoding="utf-8")
    changed = Mission.model_validate(yaml.safe_load(nav.mission_with_mode(text, "roll")))
    assert changed.mode.value == "roll"
    assert len(changed.waypoints) == 6
    assert changed.tolerance_m == 0.4
    # the shipped hexagon declares hard ground; the bench flies every terrain undeclared
    assert Mission.model_validate(yaml.safe_load(text)).ground is not None
    assert changed.ground is None
    # the thesis baseline flies at the line law's corner precision: its stop tolerance
    tight = nav.mission_with_mode(text, "omni", nav.baseline_tolerance_m())
    assert Mission.model_validate(yaml.safe_load(tight)).tolerance_m == 0.1
    survey = Mission.model_validate(
        yaml.safe_load((nav.MISSIONS_DIR / "survey.yaml").read_text(encoding="utf-8"))
    )
    assert len(survey.waypoints) == 11


def test_autopilot_duration_from_flight_csv() -> None:
    csv = "# comment\nt_boot_s,t_mono_s,x\n32.080,1.0,0\n40.000,2.0,0\n101.960,3.0,0\n"
    assert nav.autopilot_duration_s(csv) == pytest.approx(69.88)
    assert nav.autopilot_duration_s("# c\nt_boot_s,t_mono_s\n1.0,2.0\n") is None


def _columns(frame: MissionFrame, xy: list[tuple[float, float]], t0: float = 10.0) -> dict:
    """flight.csv columns for a rover at mission-frame points, facing +x, 0.5 s apart."""
    ned = [frame.to_ned(x, y) for x, y in xy]
    yaw_ned = frame.yaw_to_ned(0.0)
    n = len(xy)
    return {
        "t_boot_s": [t0 + 0.5 * i for i in range(n)],
        "north_m": [p[0] for p in ned],
        "east_m": [p[1] for p in ned],
        "yaw_ned_rad": [yaw_ned] * n,
        "x_m": [p[0] for p in xy],
        "y_m": [p[1] for p in xy],
        "yaw_rad": [0.0] * n,
        "scroll1": [0.5] * n,
        "scroll2": [-0.5] * n,
        "scroll3": [0.5] * n,
        "scroll4": [-0.5] * n,
    }


def test_true_figures_measure_the_true_path_against_the_planned_legs() -> None:
    frame = MissionFrame.start_at(NedPose(100.0, -50.0, 0.7))
    # the daemon believes it drove exactly along the first leg (x axis) to (10, 0)
    est = [(float(i), 0.0) for i in range(11)]
    cols = _columns(frame, est)
    # the truth was 0.3 m to the left of the leg (+y) the whole way, and 0.5 m short at the end
    truth_xy = [(float(i), 0.3) for i in range(10)] + [(9.5, 0.3)]
    samples = [(10.0 + 0.5 * i, *frame.to_ned(x, y)) for i, (x, y) in enumerate(truth_xy)]
    samples = [(0.0, 0.0, 0.0), *samples, (99.0, 0.0, 0.0)]  # outside the run: ignored
    fig = nav.true_figures(cols, [(10.0, 0.0)], samples)
    assert fig.samples == 11
    assert fig.xt_rms_m == pytest.approx(0.3, abs=1e-6)
    assert fig.xt_max_m == pytest.approx(0.3, abs=1e-6)
    assert fig.final_error_m == pytest.approx(math.hypot(0.5, 0.3), abs=1e-6)
    assert fig.time_s == pytest.approx(5.0)
    assert fig.effort == pytest.approx(2.0 * 5.0)  # Σ|f| = 2 for 5 s
    # no flight rows: nothing measured, no exception
    assert nav.true_figures({"t_boot_s": []}, [(1.0, 0.0)], samples) == nav.TrueFigures()


def _run(
    mission: str,
    mode: str,
    guidance: str,
    seed: int,
    rms: float | None,
    t: float | None,
    completed: bool = True,
    noise: str = "low",
    est_rms: float = 0.9,
) -> object:
    plant = "sitl_skid" if mission == "survey" else "helix"
    combo = nav.Combo(mission, mode, "hard", guidance, noise, plant)
    summary = {
        "completed": completed, "fault": None if completed else "stall: x",
        "waypoints_reached": 4 if completed else 1, "waypoints_total": 4,
        "cross_track_rms_m": est_rms, "cross_track_max_m": 1.5, "final_error_m": 0.2,
    }  # fmt: skip
    fig = nav.TrueFigures(rms, None if rms is None else 2 * rms, 0.1, t, 30.0, 100)
    return nav.result_from_summary(
        combo, seed, summary, fig, 20.0, 0 if completed else 4, ""
    )  # fmt: skip


def test_true_pose_sampler_keeps_one_sample_per_period() -> None:
    from types import SimpleNamespace

    snaps = [
        SimpleNamespace(time_boot_ms=ms, silent=silent, north_m=ms / 10, east_m=-ms / 10)
        for ms, silent in [(0, False), (5, False), (19, False), (20, True), (21, False),
                           (40, False), (41, False), (60, False)]
    ]  # fmt: skip
    fed = iter(snaps)

    def wait_for(predicate: object, timeout_s: float) -> object:
        assert callable(predicate) and timeout_s > 0
        for snap in fed:
            if predicate(snap):
                return snap
        sampler._stop.set()  # the simulator has nothing more: end like the benchmark does
        raise TimeoutError

    sampler = nav.TruePoseSampler(wait_for, period_s=0.02)
    sampler.__enter__()
    sampler._thread.join(timeout=5.0)  # ends once the fake simulator ran out of snapshots
    assert not sampler._thread.is_alive()
    sampler.__exit__(None, None, None)
    # a silent (rebooting) snapshot is not a pose; then one sample per 20 ms
    assert sampler.samples == [(0.0, 0.0, -0.0), (0.021, 2.1, -2.1), (0.041, 4.1, -4.1)]


def test_failed_run_is_reported_with_its_fault() -> None:
    r = _run("square", "omni", "thesis", 3, 0.5, 40.0, completed=False)
    assert not r.completed and r.reached == 1 and r.est_xt_rms_m == 0.9
    row = nav.run_row(r)
    assert row[6] == "FAILED" and row[7] == "1/4" and row[-1] == "4"
    (line,) = nav.failure_lines([r])
    assert "square/omni/hard/low/thesis" in line and "stall" in line and "seed 3" in line
    missing = nav.result_from_summary(
        nav.Combo("square", "omni", "mud", "line"), 5, None, nav.TrueFigures(), 3.0, 2,
        "error: helixd.yaml: control.guidance: unknown key (got 'line')",
    )  # fmt: skip
    assert not missing.completed and missing.refused and "refused" in (missing.fault or "")
    assert nav.run_row(missing)[6] == "REFUSED"


def test_aggregate_and_ratio_to_the_baseline() -> None:
    results = [
        _run("square", "roll", "thesis", 1, 0.4, 100.0),
        _run("square", "roll", "thesis", 2, 0.6, 100.0),
        _run("square", "roll", "line", 1, 0.1, 104.0),
        _run("square", "roll", "line", 2, 0.3, 112.0),  # 12 % slower than seed 2's baseline
        _run("circle", "omni", "thesis", 1, 0.5, 50.0),
        _run("circle", "omni", "line", 1, 0.3, 50.0),  # ratio 0.6
        _run("hexagon", "scroll", "thesis", 1, 0.5, 50.0),
        _run("hexagon", "scroll", "line", 1, 0.1, 40.0, completed=False),
        _run("hexagon", "omni", "thesis", 1, 0.5, 50.0),  # no new run: no ratio
    ]
    cells = nav.aggregate(results)
    sq = next(c for c in cells if c["mission"] == "square" and c["guidance"] == "thesis")
    assert sq["completed"] == "2/2" and sq["seeds"] == [1, 2]
    assert sq["xt_rms_m"]["mean"] == pytest.approx(0.5)
    assert sq["xt_rms_m"]["worst"] == pytest.approx(0.6)
    assert sq["effort"] == {"mean": 30.0, "worst": 30.0}
    assert sq["est_xt_rms_m"]["mean"] == pytest.approx(0.9)
    ratios = {(r["mission"], r["mode"]): r for r in nav.compare(results)}
    assert set(ratios) == {("square", "roll"), ("circle", "omni"), ("hexagon", "scroll")}
    sq_r = ratios[("square", "roll")]
    assert sq_r["rms_ratio"] == pytest.approx(0.4)
    assert sq_r["est_rms_ratio"] == pytest.approx(1.0)  # every synthetic summary says 0.9
    assert sq_r["time_ratio"] == pytest.approx(1.08)
    assert sq_r["worst_time_ratio"] == pytest.approx(1.12)
    assert sq_r["verdict"] == "misses (time 1.12 > 1.10)"
    # the circle's RMS (ratio 0.6) is reported, not judged; its time is
    assert ratios[("circle", "omni")]["verdict"] == "meets (time; RMS reported, not judged)"
    assert ratios[("hexagon", "scroll")]["verdict"].startswith("misses (line failed")
    rows = nav.ratio_rows(nav.compare(results))
    table = nav.format_table(nav.RATIO_HEADERS, rows, left=4)
    assert "1.12" in table and "misses (time 1.12 > 1.10)" in table
    (why,) = nav.explanations(nav.compare(results))
    assert why.startswith("square (noise low) misses time: roll/hard time 1.12 > 1.10.")
    agg = nav.format_table(nav.AGG_HEADERS, nav.aggregate_rows(cells))
    assert "0.50/0.60" in agg


def test_time_is_compared_with_the_thesis_law_at_equal_corner_precision() -> None:
    results = [
        _run("square", "roll", "thesis", 1, 0.5, 60.0),  # cuts corners: fast, imprecise
        _run("square", "roll", "thesis-tight", 1, 0.05, 80.0),  # stops at each corner
        _run("square", "roll", "line", 1, 0.05, 72.0),
    ]
    (r,) = nav.compare(results)
    assert r["rms_ratio"] == pytest.approx(0.1)  # against the plain thesis law
    assert r["time_ratio"] == pytest.approx(0.9)  # against thesis-tight, not 1.2
    assert (r["baseline"], r["time_baseline"]) == ("thesis", "thesis-tight")
    assert r["verdict"] == "meets"


def test_thesis_noise_judges_the_square_on_the_estimated_pose() -> None:
    results = [
        _run("square", "omni", "thesis", 1, 0.6, 100.0, noise="thesis", est_rms=0.6),
        _run("square", "omni", "line", 1, 0.6, 100.0, noise="thesis", est_rms=0.2),
        _run("square", "scroll", "thesis", 1, 0.6, 100.0, noise="thesis", est_rms=0.6),
        _run("square", "scroll", "line", 1, 0.2, 100.0, noise="thesis", est_rms=0.4),
    ]
    verdicts = {r["mode"]: r["verdict"] for r in nav.compare(results)}
    assert verdicts["omni"] == "meets"  # true ratio 1.0 does not count under this noise
    assert verdicts["scroll"] == "misses (RMS est 0.67 > 0.5)"  # true ratio 0.33 does not help


def test_survey_is_judged_against_autos_sitl_figures() -> None:
    auto = {"time_s": 350.0, "xt_rms_m": 0.16, "xt_max_m": 0.45, "final_error_m": 1.0}
    fast = [_run("survey", "roll", "line", s, 0.05, 340.0 + s) for s in (1, 2)]
    out = nav.survey_against_auto(fast, auto)
    assert out is not None and out["verdict"] == "meets" and out["completed"] == "2/2"
    assert out["helixd"]["time_s"]["worst"] == pytest.approx(342.0)
    slow = [_run("survey", "roll", "line", 1, 0.2, 355.0)]  # max = 2·rms = 0.4 m here
    assert nav.survey_against_auto(slow, auto)["verdict"] == (
        "misses (time 355.0 > AUTO 350.0 s, max 0.400 > half AUTO's 0.225 m)"
    )
    assert nav.survey_against_auto([_run("square", "roll", "line", 1, 0.1, 80.0)], auto) is None


def test_results_written_to_json_and_markdown(tmp_path: Path) -> None:
    results = [
        _run("square", "roll", "thesis", 1, 0.4, 100.0),
        _run("square", "roll", "line", 1, 0.1, 100.0),
        _run("square", "roll", "line", 2, None, None, completed=False),
    ]
    section = nav.results_section(results, {"runs": 3}, ["a note"])
    path = res.write_section("navigation", section, tmp_path)
    loop_section = {"latency_ms": {"p99": {"50": 2.5}}, "cpu_percent": {"50": 4.0}}
    res.write_section("control_loop", loop_section, tmp_path)
    data = json.loads(path.read_text(encoding="utf-8"))
    assert set(data) == {"navigation", "control_loop"}  # the second write kept the first
    nav_out = data["navigation"]
    assert nav_out["meta"] == {"runs": 3} and nav_out["notes"] == ["a note"]
    assert len(nav_out["runs"]) == 3 and nav_out["runs"][0]["mission"] == "square"
    assert nav_out["runs"][2]["xt_rms_m"] is None
    assert nav_out["ratios"][0]["verdict"].startswith("misses (line failed")
    assert data["control_loop"]["latency_ms"]["p99"] == {"50": 2.5}
    md = (tmp_path / "latest.md").read_text(encoding="utf-8")
    assert "## Navigation" in md and "## Control loop" in md
    assert "| square | roll | hard | low | thesis | 1/1 | 0.40 / 0.40 |" in md
    assert "a note" in md and "FAILED square/roll/hard/low/line, seed 2" in md
    assert (
        "| square | roll | hard | low | line / thesis, thesis | 0.25 | 1.00 | 1.00 | 1.00 | misses"
        in md
    )
    survey = [_run("survey", "roll", "line", 1, 0.05, 300.0)]
    res.write_section("navigation", nav.results_section(survey, {}, []), tmp_path)
    md = (tmp_path / "latest.md").read_text(encoding="utf-8")
    assert "### Survey block against ArduPilot AUTO (sitl_skid plant, 1/1 completed)" in md
    assert "| helixd (line law, corner arcs), mean / worst | 300.0 / 300.0 |" in md


def test_results_merge_and_jsonable() -> None:
    assert res.merge_section(None, "navigation", {"a": 1}) == {"navigation": {"a": 1}}
    assert res.merge_section([1, 2], "control_loop", {}) == {"control_loop": {}}
    merged = res.merge_section({"navigation": {"a": 1}, "control_loop": {"b": 2}}, "navigation", {})
    assert merged == {"navigation": {}, "control_loop": {"b": 2}}
    with pytest.raises(ValueError):
        res.merge_section({}, "other", {})
    assert res.jsonable({"x": (1.0, math.nan), 2: {"y": math.inf}}) == {
        "x": [1.0, None],
        "2": {"y": None},
    }
    assert res.fmt(None) == "-" and res.fmt(True) == "yes" and res.fmt(1.234) == "1.23"
    assert res.fmt(6) == "6"


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
        loop.Step(100, 1.0001, 1.0003, 1.0004),
        loop.Step(120, 1.0202, 1.0206, 1.0209),
        loop.Step(140, 2, 2, 2),
    ]
    lat = loop.match_latencies(sent, steps)
    assert lat.unmatched == 1
    assert lat.total_s == pytest.approx([0.0004, 0.0009])
    assert lat.wire_s == pytest.approx([0.0001, 0.0002])
    assert lat.inside_s == pytest.approx([0.0003, 0.0007])
    assert lat.compute_s == pytest.approx([0.0002, 0.0004])  # rx stamp -> command called
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


def test_control_loop_figures_and_results_section(tmp_path: Path) -> None:
    steps = [loop.Step(100 + 20 * i, 1.0 + 0.02 * i + 1e-4, 0, 1.0 + 0.02 * i + 5e-4)
             for i in range(50)]  # fmt: skip
    d = loop.DaemonRecord(
        steps=steps, window=(1.0, 2.0), cpu_s=0.04, granted_hz={}, preflight=[],
        control_rate_max_hz=50.0, fault=None, waypoints_reached=0, rx_messages=0,
        loop_ended_early=False,
    )  # fmt: skip
    a = loop.AutopilotRecord(
        pose_sends=[(100 + 20 * i, 1.0 + 0.02 * i) for i in range(51)], cpu_s=0.1, wall_s=1.0
    )
    floors = (loop.FloorRecord(0.01, 1.0, 50), loop.FloorRecord(0.02, 1.0, 50))  # 200, 400 us
    fig = loop.rate_figures(d, a, 50.0, *floors)
    assert (fig["ratio_to_floor"], fig["ratio_to_asyncio_floor"]) == pytest.approx((4.0, 2.0))
    assert fig["latency_ms"]["p99"] == pytest.approx(0.5)
    assert fig["cpu_percent"] == pytest.approx(4.0)
    assert fig["poses_sent"] == 50 and fig["control_steps"] == 50  # the 51st is past t1
    assert fig["jitter_ms"]["p99"] == pytest.approx(0.0, abs=1e-9)
    section = loop.results_section({loop.rate_key(50.0): fig, "20": {**fig, "cpu_percent": 2}}, 5)
    assert section["latency_ms"]["p99"] == {"50": pytest.approx(0.5), "20": pytest.approx(0.5)}
    assert section["cpu_percent"] == {"50": pytest.approx(4.0), "20": 2}
    res.write_section("control_loop", section, tmp_path)
    md = (tmp_path / "latest.md").read_text(encoding="utf-8")
    assert "| 50 Hz | 0.50 | 0.50 | 0.50 | 0.00 | 4.00 | 0 | 1.00 | 4.00 | 2.00 | 2.00 |" in md
    assert section["ratio_to_asyncio_floor"]["50"] == pytest.approx(2.0)


def test_floor_ratio_and_cpu_targets() -> None:
    floor = loop.FloorRecord(cpu_s=0.2, wall_s=10.0, steps=500)  # 400 us/step, 2 %
    fig = loop.floor_figures(d_cpu_s=0.8, d_steps=500, wall_s=10.0, floor=floor)
    assert fig["floor_cpu_percent"] == pytest.approx(2.0)
    assert fig["floor_us_per_step"] == pytest.approx(400.0)
    assert fig["ratio_to_floor"] == pytest.approx(4.0)  # per step, not per second
    fewer = loop.floor_figures(d_cpu_s=0.8, d_steps=250, wall_s=10.0, floor=floor)
    assert fewer["ratio_to_floor"] == pytest.approx(8.0)
    assert loop.floor_figures(0.8, 500, 10.0, None)["ratio_to_floor"] is None
    assert (
        loop.floor_figures(0.8, 500, 10.0, loop.FloorRecord(0.0, 10.0, 0))["ratio_to_floor"] is None
    )
    asy = loop.floor_figures(0.8, 500, 10.0, loop.FloorRecord(0.25, 10.0, 500), "asyncio_")
    assert asy["asyncio_floor_us_per_step"] == pytest.approx(500.0)
    assert asy["ratio_to_asyncio_floor"] == pytest.approx(3.2)  # the same daemon, other floor
    assert "ratio_to_floor" not in asy
    assert loop.cpu_target_percent(25.0) == 2.0 and loop.cpu_target_percent(50.0) == 2.0
    assert loop.cpu_target_percent(125.0) == pytest.approx(4.0)
    assert loop.cpu_target_percent(200.0) == 6.0 and loop.cpu_target_percent(400.0) == 6.0
    section = loop.results_section(
        {"50": {"cpu_percent": 3.0, "floor_cpu_percent": 1.5, "ratio_to_floor": 2.0}}, 5
    )
    assert section["floor_cpu_percent"] == {"50": 1.5} and section["ratio_to_floor"] == {"50": 2.0}
    assert section["targets"]["cpu_percent"] == {"50": 2.0, "200": 6.0}


def test_floor_echo_answers_each_pose_with_one_override() -> None:
    import socket

    from pymavlink.dialects.v20 import ardupilotmega as mavlink

    ap = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    two = bytes(ap.attitude_encode(1000, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0).pack(ap)) + bytes(
        ap.local_position_ned_encode(1000, 1.0, 2.0, 0.0, 0.0, 0.0, 0.0).pack(ap)
    )
    with (
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as rx,
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as tx,
    ):
        rx.bind(("127.0.0.1", 0))
        rx.settimeout(2.0)
        assert loop.echo_poses(loop.floor_mav(), two, tx, rx.getsockname()) == 1
        data = rx.recv(65536)
    msgs = mavlink.MAVLink(None).parse_buffer(data) or []
    assert [m.get_type() for m in msgs] == ["RC_CHANNELS_OVERRIDE"]
    assert (msgs[0].chan1_raw, msgs[0].chan5_raw) == (1500, 65535)
    assert msgs[0].get_srcSystem() == 247  # helixd's own system id, as the daemon sends


def test_a_control_loop_run_that_measured_nothing_is_named() -> None:
    good = {"control_steps": 500, "loop_ended_early": False, "fault": None}
    assert loop.measured_nothing({"50": good}) == []
    ended = {**good, "loop_ended_early": True, "fault": "gps_lost: no GPS_RAW_INT received"}
    none = {**good, "control_steps": 0}
    assert loop.measured_nothing({"50": ended, "200": none, "100": good}) == [
        "50 Hz: the flight loop ended inside the window (gps_lost: no GPS_RAW_INT received)",
        "200 Hz: no control step in the window",
    ]
