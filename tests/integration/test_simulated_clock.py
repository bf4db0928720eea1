"""Flights on the simulated clock (``run --sim --sim-clock simulated``): the simulator and the
daemon's real code share one loop and one simulated clock, over real UDP sockets, so a flight
takes the CPU time it needs and, with the noise seeded, is the same flight every time."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import yaml

from tests.support.paths import REPO_ROOT

RUNS = 10
AT_ONCE = 2  # the machine's cores
MISSION = {
    "name": "tri",
    "mode": "roll",
    "frame": "start",
    "waypoints": [{"x": 6.0, "y": 0.0}, {"x": 6.0, "y": 4.0}, {"x": 0.0, "y": 0.0}],
}


def flight_command(mission: Path, run_root: Path, seed: int) -> list[str]:
    return [
        sys.executable,
        "-m",
        "helixd",
        "run",
        "--sim",
        "--sim-clock",
        "simulated",
        "--sim-noise",
        "low",
        "--sim-seed",
        str(seed),
        "--mission",
        str(mission),
        "--config",
        str(REPO_ROOT / "config" / "helixd.yaml"),
        "--run-dir",
        str(run_root),
        "--log-level",
        "warning",
    ]


def fly_all(tmp_path: Path, seeds: list[int]) -> list[tuple[int, str, list[str]]]:
    """Each seed's flight, AT_ONCE processes at a time: (exit code, stderr, flight.csv lines)."""
    mission = tmp_path / "tri.yaml"
    mission.write_text(yaml.safe_dump(MISSION), encoding="utf-8")
    results = []
    for start in range(0, len(seeds), AT_ONCE):
        batch = []
        for k, seed in enumerate(seeds[start : start + AT_ONCE], start):
            root = tmp_path / f"run{k}"
            cmd = flight_command(mission, root, seed)
            batch.append((root, subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True)))
        for root, proc in batch:
            try:
                _, err = proc.communicate(timeout=120)
            finally:
                proc.kill()
            csvs = list(root.glob("*/flight.csv"))
            rows = csvs[0].read_text(encoding="utf-8").splitlines() if len(csvs) == 1 else []
            results.append((proc.returncode, err, rows))
    return results


def test_a_seeded_flight_flown_ten_times_records_identical_rows(tmp_path: Path) -> None:
    flights = fly_all(tmp_path, [5] * RUNS)
    for code, err, rows in flights:
        assert code == 0, err[-2000:]
        assert "helixd: RESULT ok — 3/3 waypoints" in err
        assert len(rows) > 100  # a control step each 20 ms of a flight of several seconds
    first = flights[0][2]
    for k, (_, _, rows) in enumerate(flights[1:], 2):
        differing = [i for i, (a, b) in enumerate(zip(first, rows, strict=False)) if a != b]
        assert (len(rows), differing[:3]) == (len(first), []), f"run {k} differs from run 1"


def test_another_seed_flies_another_flight(tmp_path: Path) -> None:
    """The rows are the same because the inputs are, not because nothing is recorded."""
    (code_a, err_a, rows_a), (code_b, err_b, rows_b) = fly_all(tmp_path, [5, 6])
    assert code_a == code_b == 0, err_a[-1000:] + err_b[-1000:]
    assert rows_a[2:] != rows_b[2:]


def test_a_cold_autopilot_on_the_simulated_clock_is_no_slow_stream(tmp_path: Path) -> None:
    """Before: each run on the simulated clock logged 9 `stream_slow` warnings (e.g.
    `LOCAL_POSITION_NED observed_hz=0.0 granted_hz=40.0`): helixd connects while the simulated
    autopilot still boots (only HEARTBEAT) and before its EKF has an origin (no
    LOCAL_POSITION_NED, as ArduPilot), which a wall-clock run, starting seconds later, never
    saw. Neither is a slow stream; and the RESULT line claims no wall time it did not measure."""
    ((code, err, rows),) = fly_all(tmp_path, [5])
    assert code == 0 and len(rows) > 100, err[-2000:]
    assert "stream_slow" not in err and "streams_silent" not in err, err
    assert "level=warning" not in err, err
    assert "autopilot time (simulated clock), exit 0" in err, err
