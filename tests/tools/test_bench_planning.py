"""The planning section of bench/results: merged beside the others and rendered."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from tests.support.paths import REPO_ROOT

ROOT = REPO_ROOT
sys.path.insert(0, str(ROOT / "tools"))

from bench_results import render_markdown, write_section  # noqa: E402


def test_planning_section_is_merged_and_rendered(tmp_path: Path) -> None:
    (tmp_path / "latest.json").write_text(json.dumps({"control_loop": {"meta": {"x": 1}}}))
    section = {
        "cases": {
            "clutter": {
                "total_ms": {"median": 812.4, "worst": 901.0},
                "inflate_ms": 100.0,
                "search_ms": 600.0,
                "shortcut_ms": 50.0,
                "legs": 31,
                "path_m": 296.2,
                "blocked_percent": 26.0,
            }
        },
        "target": "clutter < 1000 ms",
        "target_met": True,
        "meta": {"grid": "2000 × 2000"},
    }
    write_section("planning", section, tmp_path)
    merged = json.loads((tmp_path / "latest.json").read_text())
    assert set(merged) == {"control_loop", "planning"}
    md = render_markdown(merged)
    assert (
        "## Planning" in md and "| clutter | 812 | 901 | 100 | 600 | 50 | 31 | 296.2 | 26 |" in md
    )
    assert "Target: clutter < 1000 ms — met" in md
    assert (tmp_path / "latest.md").read_text() == md
