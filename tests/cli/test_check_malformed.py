"""The malformed-file corpus (``tests/unit/malformed/``) through ``helixd check``, in-process.

Every file must give exit 2, a short message naming the file and the expected fragments, and
no traceback. ``c_*`` files are configs (checked with the shipped square), ``m_*`` missions.
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from helixd.cli.app import app
from tests.support.paths import DATA_DIR, REPO_ROOT

ROOT = REPO_ROOT
CORPUS = DATA_DIR / "malformed"
SQUARE = ROOT / "config" / "missions" / "square.yaml"
MAX_MESSAGE_CHARS = 500  # per error line; a 10 MB echo must never come back

# file → fragments that must all appear in the output (the table is the corpus's sidecar)
EXPECTED: dict[str, list[str]] = {
    "c_alias_bomb.yaml": ["alias *a at line 3", "not allowed"],
    "c_alias_simple.yaml": ["alias *r at line 3"],
    "c_binary.yaml": ["not UTF-8", "offset 128"],
    "c_complex_key.yaml": ["a list or mapping used as a key at line 1"],
    "c_deep_mapping.yaml": ["nested deeper than 32 levels", "line 33"],
    "c_deep_nesting.yaml": ["nested deeper than 32 levels at line 1"],
    "c_duplicate_nested.yaml": ["duplicate key 'max_speed_mps' at lines 2 and 3"],
    "c_duplicate_safety.yaml": ["duplicate key 'safety' at lines 1 and 5"],
    "c_huge_float.yaml": ["vehicle.max_rpm", "allowed: > 1.0 and <= 2000.0"],
    "c_huge_int.yaml": ["line 2", "100 digits"],
    "c_inf.yaml": ["control.max_speed_mps", "finite", "inf"],
    "c_latin1.yaml": ["not UTF-8", "0xfc"],
    "c_link_url.yaml": ["link.url", "unknown scheme 'http'", "allowed forms"],
    "c_long_value.yaml": ["control.max_speed_mps", "100002 characters", "number"],
    "c_merge_key.yaml": ["merge key '<<' at line 2"],
    "c_nan.yaml": ["vehicle.lx_m", "finite", "nan"],
    "c_non_utf8.yaml": ["not UTF-8", "0xff at offset 22"],
    "c_null_section.yaml": ["vehicle", "mapping"],
    "c_on_number.yaml": ["vehicle.max_rpm", "'on'", "not numbers"],
    "c_overflow_float.yaml": ["vehicle.max_rpm", "finite"],
    "c_polygon_bowtie.yaml": ["safety.geofence_polygon_ne_m", "intersect itself"],
    "c_polygon_collinear.yaml": ["safety.geofence_polygon_ne_m", "area 0"],
    "c_polygon_nan.yaml": ["safety.geofence_polygon_ne_m.1.1", "finite"],
    "c_polygon_two_vertices.yaml": ["safety.geofence_polygon_ne_m", "at least 3 vertices, got 2"],
    "c_pose_stale.yaml": ["safety.pose_stale_s = 0.1", "link.pose_rate_min_hz"],
    "c_python_tag.yaml": ["explicit tag", "python/object/apply", "not allowed"],
    "c_sexagesimal.yaml": ["startup.connect_timeout_s", "'1:30'", "number"],
    "c_start_eq_takeover.yaml": [
        "safety.takeover.switch_channel and startup.start_switch_channel are both 7"
    ],
    "c_stick_99.yaml": ["safety.takeover.stick_channels.0", "got 99", "allowed range 1 .. 18"],
    "c_stop_timeout.yaml": ["actuation.stop_timeout_s = 0.8", "safety.fallback_deadline_s = 0.5"],
    "c_tabs.yaml": ["line 2, column 1", "tab"],
    "c_takeover_on_scroll.yaml": [
        "safety.takeover.switch_channel = 1",
        "drives scroll 1",
        "allowed: a channel 1..18 other than [1, 2, 3, 4]",
    ],
    "c_top_list.yaml": ["(top level)", "expected a mapping", "list"],
    "c_top_scalar.yaml": ["(top level)", "expected a mapping", "str"],
    "c_true_in_list.yaml": ["safety.takeover", "stick_channels", "true/false is not a number"],
    "c_true_number.yaml": ["vehicle", "output_clamp", "true/false is not a number"],
    "c_two_documents.yaml": ["a second YAML document at line 2"],
    "c_unclosed_flow.yaml": ["not valid YAML", "line 2"],
    "c_unknown_key.yaml": ["speed", "unknown key", "allowed keys here"],
    "c_yes_number.yaml": ["control.max_speed_mps", "'yes'", "not numbers"],
    "m_alias_bomb.yaml": ["alias *a at line 4"],
    "m_bad_indent.yaml": ["not valid YAML", "line 5"],
    "m_comments_only.yaml": ["name: missing required field", "waypoints: missing"],
    "m_deep_nesting.yaml": ["nested deeper than 32 levels at line 3"],
    "m_duplicate_in_flow.yaml": ["duplicate key 'x' twice on line 4"],
    "m_duplicate_mode.yaml": ["duplicate key 'mode' at lines 2 and 5"],
    "m_empty.yaml": ["name: missing required field", "mode: missing required field"],
    "m_nan.yaml": ["waypoint 1 (waypoints[0]): x", "finite"],
    "m_no_coordinate.yaml": ["waypoint 1 (waypoints[0]): y", "'no'", "not numbers"],
    "m_nul_bytes.yaml": ["not valid YAML", "control characters"],
    "m_off_heading.yaml": ["waypoint 1 (waypoints[0]): heading_deg", "'off'"],
    "m_outside_fence.yaml": [
        "waypoint 2 (waypoints[1]): 150.0 m from the start point",
        "safety.geofence_radius_m = 100.0 m",
    ],
    "m_too_long.yaml": ["estimated time 4589 s", "safety.mission_time_limit_s = 1800 s"],
    "m_top_list.yaml": ["(top level)", "expected a mapping", "list"],
    "m_true_tolerance.yaml": ["tolerance_m", "true/false is not a number"],
    "m_waypoints_mapping.yaml": ["waypoints", "a list"],
    "m_yes_coordinate.yaml": ["waypoint 1 (waypoints[0]): x", "'yes'"],
}


def _check(path: Path) -> tuple[int, str, float]:
    if path.name.startswith("c_"):
        args = ["check", "--config", str(path), "--mission", str(SQUARE)]
    else:
        args = ["check", "--mission", str(path)]
    t0 = time.perf_counter()
    result = CliRunner().invoke(app, args)
    elapsed = time.perf_counter() - t0
    # typer exits through SystemExit; anything else escaping is a crash
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result.exit_code, result.output, elapsed


def test_corpus_is_complete() -> None:
    files = sorted(p.name for p in CORPUS.iterdir() if p.is_file())
    assert len(files) >= 40
    assert files == sorted(EXPECTED), "every corpus file needs its expected fragments"


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_malformed_file_is_refused_in_one_short_message(name: str) -> None:
    path = CORPUS / name
    code, output, elapsed = _check(path)
    assert code == 2, output
    assert "Traceback" not in output
    lines = [ln for ln in output.splitlines() if ln.startswith("error:")]
    assert lines, output
    for line in lines:
        assert str(path) in line, line
        assert len(line) <= MAX_MESSAGE_CHARS, f"{len(line)} characters: {line[:200]}"
    for fragment in EXPECTED[name]:
        assert fragment in output, f"{fragment!r} not in {output!r}"
    assert elapsed < 5.0, f"{name} took {elapsed:.1f} s"


def test_alias_bomb_answers_at_once_with_a_short_message() -> None:
    path = CORPUS / "c_alias_bomb.yaml"
    assert path.stat().st_size < 1000
    code, output, elapsed = _check(path)
    print(f"alias bomb: exit {code} in {elapsed * 1000:.0f} ms, {len(output)} characters")
    assert code == 2
    assert elapsed < 2.0
    assert len(output) < 300
