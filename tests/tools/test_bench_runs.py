"""Each ``make bench`` tool run for real with its smallest arguments, its results written into
a temporary directory (never bench/results/): the test fails when the tool measured nothing
(no samples, no run, an empty section, a figure that is not a finite number).

The tools run as ``make bench`` runs them, as their own processes (they configure logging
for themselves), each in a few seconds of wall time. The benches that fly do so on the
simulated clock, their default (seeded: the same flight on any machine), so no verdict here
depends on the machine's speed: before, the navigation and amphibious smoke flights ran at
speed-up 20 on the wall clock and failed on a machine about 2x slower than this one.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from tests.support.paths import REPO_ROOT

pytestmark = pytest.mark.integration

TOOL_TIMEOUT_S = 180.0  # a hang guard, not a verdict: each normally takes 5-20 s


def run_tool(name: str, results_dir: Path, *args: str) -> tuple[int, str, dict[str, Any]]:
    """``tools/<name>.py args --results-dir results_dir``: exit status, output, latest.json."""
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env.pop("NOTIFY_SOCKET", None)
    proc = subprocess.run(
        [sys.executable, str(REPO_ROOT / "tools" / f"{name}.py"), *args,
         "--results-dir", str(results_dir)],
        capture_output=True, text=True, timeout=TOOL_TIMEOUT_S, cwd=REPO_ROOT, env=env,
    )  # fmt: skip
    output = proc.stdout + proc.stderr
    latest = results_dir / "latest.json"
    assert latest.is_file(), f"{name} wrote no results (exit {proc.returncode}):\n{output}"
    assert (results_dir / "latest.md").is_file()
    return proc.returncode, output, json.loads(latest.read_text(encoding="utf-8"))


def finite(value: Any, what: str, output: str) -> float:
    """``value`` as a finite number (the results write NaN and infinity as null)."""
    assert isinstance(value, int | float) and not isinstance(value, bool), (what, value, output)
    assert math.isfinite(value), (what, value, output)
    return float(value)


def test_control_loop_bench_measures_the_loop(tmp_path: Path) -> None:
    code, out, data = run_tool(
        "bench_control_loop", tmp_path,
        "--seconds", "1", "--warmup-s", "0.5", "--rate-hz", "50", "--event-loop", "asyncio",
    )  # fmt: skip
    assert code == 0, out
    assert set(data) == {"control_loop"}, out
    fig = data["control_loop"]["per_rate"]["50"]
    # the flight ran through the window: no watchdog ended it (a missing stream would)
    assert fig["fault"] is None and fig["loop_ended_early"] is False, out
    assert "WARNING" not in out and "no samples" not in out, out
    # 1 s at 50 Hz: 50 poses on time; a loaded or 2x slower machine may send fewer, and the
    # test asks only that the loop was measured (the figures judge the machine, not this test)
    assert fig["poses_sent"] >= 10 and fig["control_steps"] >= 10, out
    for key in ("latency_ms", "latency_in_daemon_ms", "autopilot_rtt_ms", "jitter_ms"):
        assert fig[key]["n"] >= 10, (key, out)
        for q in ("p50", "p99", "max"):
            assert finite(fig[key][q], f"{key}.{q}", out) >= 0.0
    assert finite(fig["cpu_percent"], "cpu_percent", out) > 0.0
    # both floors answered the same autopilot and give a ratio; on a loaded machine a floor's
    # 1 s window can stay empty, and then the bench says so instead of printing a figure
    for prefix, label in (("", "floor: bare pymavlink echo loop"), ("asyncio_", "same echo as")):
        if fig[f"{prefix}floor_cpu_percent"] is None:
            assert fig[f"ratio_to_{prefix}floor"] is None, out
            said = [line for line in out.splitlines() if label in line]
            assert said and "not measured: " in said[0], (label, out)
            continue
        assert finite(fig[f"{prefix}floor_cpu_percent"], f"{prefix}floor", out) > 0.0
        assert finite(fig[f"ratio_to_{prefix}floor"], f"ratio_to_{prefix}floor", out) > 0.0
    headline = data["control_loop"]["latency_ms"]["p99"]
    assert finite(headline["50"], "latency p99", out) == fig["latency_ms"]["p99"]


def test_navigation_bench_flies_and_measures_one_run(tmp_path: Path) -> None:
    code, out, data = run_tool(
        "bench_navigation", tmp_path,
        "--only", "square/roll", "--terrain", "hard", "--guidance", "line", "--noise", "none",
        "--no-survey", "--runs", "1", "--jobs", "1",
    )  # fmt: skip
    assert code == 0, out
    nav = data["navigation"]
    assert nav["meta"]["clock"] == "simulated" and nav["meta"]["speedup"] is None, out
    assert nav["meta"]["runs"] == 1 and nav["meta"]["completed"] == 1, out
    (run,) = nav["runs"]
    assert run["completed"] is True and run["mission"] == "square", run
    for key in ("xt_rms_m", "xt_max_m", "final_error_m", "est_xt_rms_m", "time_s", "effort"):
        assert finite(run[key], key, out) >= 0.0
    assert run["time_s"] > 0.0 and run["effort"] > 0.0 and run["true_samples"] > 0  # it drove
    (cell,) = nav["cells"]
    assert cell["completed"] == "1/1"
    assert finite(cell["xt_rms_m"]["mean"], "cell xt_rms_m", out) == run["xt_rms_m"]


def test_planning_bench_plans_every_map(tmp_path: Path) -> None:
    code, out, data = run_tool("bench_planning", tmp_path, "--repeats", "1", "--weight", "1.1")
    # the target (clutter < 1 s) is a verdict on the figures, not part of measuring them
    assert code in (0, 1), out
    plan = data["planning"]
    assert set(plan["cases"]) == {"clutter", "walls", "clutter_w1.1"}, out
    for name, case in plan["cases"].items():
        assert len(case["total_ms"]["runs"]) == 1, name
        assert finite(case["total_ms"]["worst"], f"{name} total", out) > 0.0
        for key in ("inflate_ms", "search_ms", "shortcut_ms"):
            assert finite(case[key], f"{name} {key}", out) >= 0.0
        assert case["legs"] >= 1 and case["grid_path_cells"] > 0, name
        assert finite(case["path_m"], f"{name} path", out) >= case["straight_m"] > 0.0
    assert plan["target_met"] is (code == 0)


def test_amphibious_bench_flies_the_crossing_by_the_medium(tmp_path: Path) -> None:
    code, out, data = run_tool(
        "bench_amphibious", tmp_path, "--only", "crossing", "--policy", "media", "--jobs", "1",
    )  # fmt: skip
    assert code == 0, out
    assert set(data) == {"amphibious"}, out
    assert data["amphibious"]["clock"] == "simulated", out
    assert "simulated clock" in out, out
    fig = data["amphibious"]["crossing"]["media"]
    assert fig["samples"] > 100, out  # the simulator's truth was sampled
    assert fig["completed"] is True, out  # bank → water → bank, each stretch in its mode
    assert finite(fig["time_s"], "time", out) > 60.0  # 60 m at most 0.6 m/s
    assert finite(fig["energy_j"], "energy", out) > 0.0
    assert {"hard", "water"} <= set(fig["rms_m"]), out
    for medium, rms in fig["rms_m"].items():
        assert 0.0 <= finite(rms, f"rms {medium}", out) < 1.0, out
