"""Malformed config and mission files: each gives its own clear message, never a traceback."""

from __future__ import annotations

import itertools
import math
import subprocess
import sys
from pathlib import Path

import pytest

from helixd.base.plan import MissionFrameKind, MotionMode
from helixd.config.load import load_config
from helixd.config.root import HelixdConfig
from helixd.files.models import ConfigFileError
from helixd.mission.model import load_mission
from helixd.mission.resolve import resolve_plan
from tests.support.paths import REPO_ROOT

ROOT = REPO_ROOT


def _write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


# (file text, substrings every one of which must appear in the single problem line)
BAD_CONFIGS = {
    "unknown_top_key": ("vehicle: {}\nspeed: 3\n", ["speed", "unknown key", "allowed keys here"]),
    "unknown_nested_key": (
        "control:\n  max_speed: 0.5\n",
        ["control.max_speed", "unknown key", "max_speed_mps"],
    ),
    "out_of_range": (
        "vehicle:\n  output_clamp: 1.5\n",
        ["vehicle.output_clamp", "got 1.5", "allowed: > 0.0 and <= 1.0"],
    ),
    "negative_gain": (
        "control:\n  yaw_pid: {kp: -1, ki: 0, kd: 0, integral_limit: 0.1}\n",
        ["control.yaw_pid.kp", "got -1", "allowed range 0.0 .. 100.0"],
    ),
    "wrong_type": (
        "control:\n  waypoint_tolerance_m: one metre\n",
        ["control.waypoint_tolerance_m", "'one metre'", "number"],
    ),
    "bad_backend": (
        "actuation:\n  backend: pwm\n",
        ["actuation.backend", "'pwm'", "rc_override", "servo", "dry_run"],
    ),
    "channel_out_of_range": (
        "actuation:\n  channels:\n"
        "    - {channel: 1}\n    - {channel: 2}\n    - {channel: 3}\n    - {channel: 19}\n",
        ["actuation.channels.3.channel", "got 19", "allowed range 1 .. 18"],
    ),
    "duplicate_channel": (
        "actuation:\n  channels:\n"
        "    - {channel: 1}\n    - {channel: 1}\n    - {channel: 3}\n    - {channel: 4}\n",
        ["actuation", "each scroll needs its own channel", "[1, 1, 3, 4]"],
    ),
    "pwm_order": (
        "actuation:\n  channels:\n"
        "    - {channel: 1, pwm_min_us: 1600}\n    - {channel: 2}\n"
        "    - {channel: 3}\n    - {channel: 4}\n",
        ["actuation.channels.0", "pwm_min_us < pwm_trim_us < pwm_max_us", "1600 / 1500 / 2000"],
    ),
    "repeat_rate_too_low": (
        "actuation:\n  repeat_rate_hz: 2\n",
        ["actuation.repeat_rate_hz", "got 2", "allowed range 10.0 .. 100.0"],
    ),
    "gps_stale_below_telemetry_period": (
        "link:\n  telemetry_rate_hz: 1.0\n",
        [
            "safety.gps_stale_s = 0.6 s must be > 1 / min(link.telemetry_rate_hz, "
            "link.pose_rate_min_hz) + 0.2 s = 1.200 s"
        ],
    ),
    "gps_stale_below_the_stepped_down_telemetry_period": (
        "link:\n  pose_rate_min_hz: 2.5\n",
        ["safety.gps_stale_s = 0.6 s", "+ 0.2 s = 0.600 s"],
    ),
    "switch_stale_below_the_rc_channels_period": (
        "serve:\n  switch_stale_s: 0.15\n",
        ["serve.switch_stale_s = 0.15 s must be > 1 / min(link.telemetry_rate_hz"],
    ),
    "gps_fix_below_2d": (
        "safety:\n  gps_min_fix_type: 1\n",
        ["safety.gps_min_fix_type", "got 1", "allowed range 2 .. 6"],
    ),
    "not_a_mapping": ("- just\n- a list\n", ["(top level)", "expected a mapping", "list"]),
    "bad_yaml": ("vehicle: {scroll_radius_m: 0.2\n", ["not valid YAML", "line"]),
}


@pytest.mark.parametrize("case", sorted(BAD_CONFIGS))
def test_bad_config_gives_specific_message(tmp_path: Path, case: str) -> None:
    text, needles = BAD_CONFIGS[case]
    path = _write(tmp_path, f"{case}.yaml", text)
    with pytest.raises(ConfigFileError) as info:
        load_config(path)
    problems = info.value.problems
    assert len(problems) == 1, problems
    line = problems[0]
    assert line.startswith(str(path)), line
    for needle in needles:
        assert needle in line, f"{needle!r} not in {line!r}"


def test_every_problem_reported_once(tmp_path: Path) -> None:
    path = _write(
        tmp_path,
        "many.yaml",
        "vehicle:\n  max_rpm: 0\ncontrol:\n  max_speed_mps: 9\nbogus: 1\n",
    )
    with pytest.raises(ConfigFileError) as info:
        load_config(path)
    text = "\n".join(info.value.problems)
    assert len(info.value.problems) == 3
    for field in ("vehicle.max_rpm", "control.max_speed_mps", "bogus"):
        assert field in text


def test_missing_file_names_it(tmp_path: Path) -> None:
    with pytest.raises(ConfigFileError) as info:
        load_config(tmp_path / "nope.yaml")
    assert info.value.problems == [f"{tmp_path / 'nope.yaml'}: file not found"]


def test_shipped_config_equals_defaults() -> None:
    assert load_config(ROOT / "config" / "helixd.yaml") == HelixdConfig()


def test_defaults_come_from_the_thesis() -> None:
    cfg = HelixdConfig()
    assert cfg.vehicle.scroll_radius_m == 0.175
    assert cfg.vehicle.lx_m + cfg.vehicle.ly_m == pytest.approx(1.073)
    assert cfg.vehicle.max_rpm == 195
    assert cfg.vehicle.output_clamp == 0.9
    assert (cfg.control.distance_pid.kp, cfg.control.distance_pid.ki) == (1.2, 0.0002)
    assert (cfg.control.yaw_pid.kp, cfg.control.yaw_pid.kd) == (8.0, 0.05)
    assert cfg.control.heading_threshold_rad == 0.2
    assert cfg.control.waypoint_tolerance_m == 1.0
    assert cfg.control.max_speed_mps == 0.6
    assert cfg.link.source_system == 247 and cfg.link.source_component == 191


BAD_MISSIONS = {
    "empty_list": (
        "name: e\nmode: roll\nwaypoints: []\n",
        ["waypoints", "empty"],
    ),
    "nan": (
        "name: n\nmode: roll\nwaypoints:\n  - {x: .nan, y: 1}\n",
        ["waypoint 1 (waypoints[0]): x", "finite"],
    ),
    "inf": (
        "name: n\nmode: roll\nwaypoints:\n  - {x: 1, y: .inf}\n",
        ["waypoint 1 (waypoints[0]): y", "finite"],
    ),
    "duplicate_consecutive": (
        "name: d\nmode: roll\nwaypoints:\n  - {x: 1, y: 1}\n  - {x: 1, y: 1}\n",
        ["waypoint 2 (waypoints[1])", "same point as waypoint 1"],
    ),
    "too_far": (
        "name: f\nmode: omni\nwaypoints:\n  - {x: 900, y: 0}\n",
        ["waypoint 1 (waypoints[0])", "900.0 m from the origin", "max_range_m = 500.0"],
    ),
    "unknown_mode": (
        "name: m\nmode: hover\nwaypoints:\n  - {x: 1, y: 0}\n",
        ["mode", "'hover'", "roll", "scroll", "omni"],
    ),
    "unknown_frame": (
        "name: m\nmode: roll\nframe: enu\nwaypoints:\n  - {x: 1, y: 0}\n",
        ["frame", "'enu'", "start", "local_ned", "global"],
    ),
    "wrong_coordinates_for_frame": (
        "name: m\nmode: roll\nframe: local_ned\nwaypoints:\n  - {x: 1, y: 0}\n",
        ["waypoint 1 (waypoints[0])", "frame 'local_ned' needs exactly north and east"],
    ),
    "missing_mode": (
        "name: m\nwaypoints:\n  - {x: 1, y: 0}\n",
        ["mode", "missing required field"],
    ),
    "unknown_waypoint_key": (
        "name: m\nmode: roll\nwaypoints:\n  - {x: 1, y: 0, speed: 3}\n",
        ["waypoint 1 (waypoints[0])", "speed: unknown key", "hold_s"],
    ),
    "bad_latitude": (
        "name: g\nmode: roll\nframe: global\nwaypoints:\n  - {lat: 95, lon: 10}\n",
        ["waypoint 1 (waypoints[0]): lat", "got 95", "allowed range -90.0 .. 90.0"],
    ),
}


@pytest.mark.parametrize("case", sorted(BAD_MISSIONS))
def test_bad_mission_gives_specific_message(tmp_path: Path, case: str) -> None:
    text, needles = BAD_MISSIONS[case]
    path = _write(tmp_path, f"{case}.yaml", text)
    with pytest.raises(ConfigFileError) as info:
        load_mission(path)
    line = "\n".join(info.value.problems)
    assert line.startswith(str(path)), line
    for needle in needles:
        assert needle in line, f"{needle!r} not in {line!r}"


@pytest.mark.parametrize(
    ("name", "mode", "count"),
    [
        ("square", MotionMode.ROLL, 4),
        ("hexagon", MotionMode.OMNI, 6),
        ("circle", MotionMode.SCROLL, 25),
    ],
)
def test_shipped_missions(name: str, mode: MotionMode, count: int) -> None:
    cfg = HelixdConfig()
    mission = load_mission(ROOT / "config" / "missions" / f"{name}.yaml", cfg.mission)
    assert mission.mode is mode
    assert mission.frame is MissionFrameKind.START
    plan = resolve_plan(mission, cfg.control, cfg.mission)
    assert len(plan.waypoints) == count


def test_square_is_ten_metres_counter_clockwise() -> None:
    cfg = HelixdConfig()
    plan = resolve_plan(
        load_mission(ROOT / "config/missions/square.yaml"), cfg.control, cfg.mission
    )
    pts = [(0.0, 0.0)] + [(w.x_m, w.y_m) for w in plan.waypoints]
    # shoelace: positive area ⇔ counter-clockwise in a right-handed (x fwd, y left) frame
    area = sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in itertools.pairwise(pts)) / 2
    assert area == pytest.approx(100.0)
    assert plan.path_length_m() == pytest.approx(40.0)


def test_circle_geometry() -> None:
    cfg = HelixdConfig()
    plan = resolve_plan(
        load_mission(ROOT / "config/missions/circle.yaml"), cfg.control, cfg.mission
    )
    assert (plan.waypoints[0].x_m, plan.waypoints[0].y_m) == (4.0, 2.0)
    for wp in plan.waypoints:
        assert math.hypot(wp.x_m - 2.0, wp.y_m - 2.0) == pytest.approx(2.0, abs=1e-3)


def test_cli_check_prints_plan_and_rejects_bad_files(tmp_path: Path) -> None:
    ok = subprocess.run(
        [
            sys.executable,
            "-m",
            "helixd",
            "check",
            "--mission",
            str(ROOT / "config/missions/square.yaml"),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert ok.returncode == 0, ok.stderr
    assert "path    : 40.0 m at 0.60 m/s" in ok.stdout
    bad_cfg = _write(tmp_path, "c.yaml", "control:\n  max_speed_mps: 9\n")
    bad_msn = _write(tmp_path, "m.yaml", "name: m\nmode: fly\nwaypoints: []\n")
    res = subprocess.run(
        [sys.executable, "-m", "helixd", "check", "-c", str(bad_cfg), "-m", str(bad_msn)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert res.returncode == 2
    assert "Traceback" not in res.stderr
    assert "control.max_speed_mps" in res.stderr and "mode" in res.stderr


def test_shipped_sitl_skid_config_is_the_sitl_suites() -> None:
    from tests.support.skid_setup import helixd_sitl_config

    expected = helixd_sitl_config("rc_override", HelixdConfig().link.url)
    assert load_config(ROOT / "config" / "sitl-skid.yaml") == HelixdConfig.model_validate(expected)


@pytest.mark.parametrize(
    ("key", "fragment"),
    [
        (None, "cannot read"),  # the file does not exist
        (b"short", "expected 32 raw bytes or 64 hex characters, found 5 bytes"),
        (b"zz" * 32, "expected 32 raw bytes or 64 hex characters, found 64 bytes"),
    ],
)
def test_a_signing_key_run_could_not_use_is_refused_at_load(
    tmp_path: Path, key: bytes | None, fragment: str
) -> None:
    """Regression: `check` accepted a config naming a missing key file; `run` would only find
    out when the link opened. The loader reads it as the link will."""
    key_file = tmp_path / "helix.key"
    if key is not None:
        key_file.write_bytes(key)
    cfg = _write(tmp_path, "c.yaml", f"link:\n  signing_key_file: {key_file}\n")
    with pytest.raises(ConfigFileError) as info:
        load_config(cfg)
    [line] = info.value.problems
    assert line.startswith(f"{cfg}: link.signing_key_file: ")
    assert str(key_file) in line and fragment in line


def test_a_readable_signing_key_loads(tmp_path: Path) -> None:
    key_file = tmp_path / "helix.key"
    key_file.write_text(bytes(range(32)).hex() + "\n")
    cfg = _write(tmp_path, "c.yaml", f"link:\n  signing_key_file: {key_file}\n")
    assert load_config(cfg).link.signing_key_file == key_file
