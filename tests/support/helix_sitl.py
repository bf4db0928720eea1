"""helixd's configuration and yardsticks for the Helix plant on real ArduPilot SITL
(``helixd plant`` + ``ardurover --model JSON``), and the same flight on the built-in simulator.

Both flights are measured on the true pose: on SITL the plant's own truth file (what the rover
really did; SITL's EKF only estimates it), on the built-in simulator the pose of a flight with
no pose noise (``--sim-noise none``: the pose helixd steers by is the truth). Both against the
mission laid out in the frame helixd flew in (its first control step, flight.csv). The
difference between the two rows is the built-in simulator's truth gap: what real ArduPilot
(EKF3, output pipeline, timing) changes.
"""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from helixd.config.control import ControlConfig
from helixd.config.mission import MissionLimits
from helixd.mission.model import load_mission
from helixd.mission.resolve import resolve_plan
from helixd.recorder.track import TrackMetrics, TrackPoint
from tests.support.paths import REPO_ROOT
from tests.support.skid_setup import HELIXD_SYSID, helixd_start_frame, metrics_in_frame

MISSIONS = REPO_ROOT / "config" / "missions"
SIM_SEED = 0  # the twin's noise seed (no pose noise; the seed fixes the rest)
SIM_FLIGHT_TIMEOUT_S = 300.0
# the ground of the SITL suite's Helix plant and of its twin (the file says why)
SITL_GROUND = REPO_ROOT / "tests" / "sitl" / "hard-scrolls.yaml"


def helix_sitl_config(url: str, backend: str = "rc_override") -> dict[str, Any]:
    """The helixd.yaml for a real Helix on SITL: the defaults (the thesis's geometry and gains,
    scroll n on RC channel n, 1000..2000 µs) with helixd's GCS id and SITL's patient startup."""
    return {
        "link": {"url": url, "source_system": HELIXD_SYSID, "heartbeat_rate_hz": 5.0},
        "actuation": {"backend": backend},
        "startup": {
            "connect_timeout_s": 60.0,
            "arm_timeout_s": 60.0,
            "arm_retry_interval_s": 1.0,
        },
    }


def mission_waypoints(mission: Path) -> list[tuple[float, float]]:
    """The plan's waypoints in the mission's ``start`` frame (x forward, y left; m)."""
    plan = resolve_plan(load_mission(mission), ControlConfig(), MissionLimits())
    return [(w.x_m, w.y_m) for w in plan.waypoints]


def truth_track(truth_csv: Path) -> list[TrackPoint]:
    """The Helix plant's true pose (``helixd plant --truth-csv``), plant time."""
    with truth_csv.open(encoding="utf-8", newline="") as fh:
        return [
            TrackPoint(float(r["t_s"]), float(r["north_m"]), float(r["east_m"]))
            for r in csv.DictReader(fh)
        ]


def flight_track(run_dir: Path) -> list[TrackPoint]:
    """The pose helixd steered by, from flight.csv (autopilot time)."""
    lines = (run_dir / "flight.csv").read_text(encoding="utf-8").splitlines()
    rows = [ln.split(",") for ln in lines if ln and not ln.startswith("#")]
    col = {name: i for i, name in enumerate(rows[0])}
    return [
        TrackPoint(float(r[col["t_boot_s"]]), float(r[col["north_m"]]), float(r[col["east_m"]]))
        for r in rows[1:]
    ]


def flown_metrics(run_dir: Path, track: list[TrackPoint], mission: Path) -> TrackMetrics | None:
    """``track`` against ``mission`` laid out where helixd's first control step stood."""
    start, _ = helixd_start_frame(run_dir)
    return metrics_in_frame(track, mission_waypoints(mission), start)


@dataclass(frozen=True)
class SimTwin:
    exit_code: int
    summary: dict[str, Any]
    metrics: TrackMetrics | None
    run_dir: Path  # its flight.csv, events, summary


def fly_on_builtin_sim(
    work: Path,
    mission: Path,
    mode: str | None,
    terrain: str,
    config: dict[str, Any],
    media: Path | None = None,
) -> SimTwin:
    """The same flight by ``helixd run --sim`` (exact pose, ``terrain``, the ``media`` map),
    measured alike (metrics only for a ``start``-frame mission: None otherwise). The twin runs
    on the simulated clock: the same figures on every run, however loaded the machine is
    with SITL instances side by side (on the wall clock at speed-up 10, a loaded machine made
    it 11 % slower)."""
    work.mkdir(parents=True, exist_ok=True)
    cfg = {k: v for k, v in config.items() if k != "link"}
    cfg_path = work / "helixd-sim.yaml"
    cfg_path.write_text(yaml.safe_dump(cfg, sort_keys=False), encoding="utf-8")
    run_root = work / "runs"
    cmd = [
        sys.executable, "-m", "helixd", "run", "--sim", "--sim-clock", "simulated",
        "--sim-seed", str(SIM_SEED),
        "--sim-terrain", terrain, "--sim-noise", "none",
        "--mission", str(mission), "--config", str(cfg_path), "--run-dir", str(run_root),
        "--log-level", "warning",
    ]  # fmt: skip
    cmd += [] if mode is None else ["--mode", mode]  # None: the mission's (the media plan's)
    cmd += ["--sim-ground", str(SITL_GROUND)]  # the plant's ground (tests/sitl/conftest.py)
    if media is not None:
        cmd += ["--sim-media", str(media)]
    done = subprocess.run(
        cmd, cwd=work, capture_output=True, text=True, timeout=SIM_FLIGHT_TIMEOUT_S, check=False
    )
    run_dir = sorted(p for p in run_root.iterdir() if p.is_dir())[-1]
    summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    metrics = flown_metrics(run_dir, flight_track(run_dir), mission)
    return SimTwin(done.returncode, summary, metrics, run_dir)


def gap_line(name: str, sitl: TrackMetrics, sim: TrackMetrics) -> str:
    """One printed row of the truth gap (SITL − built-in simulator)."""
    return (
        f"{name}: SITL {sitl.cross_track_rms_m:.3f} / {sitl.cross_track_max_m:.3f} / "
        f"{sitl.final_error_m:.3f} m, {sitl.elapsed_s:.1f} s | helixd sim "
        f"{sim.cross_track_rms_m:.3f} / {sim.cross_track_max_m:.3f} / {sim.final_error_m:.3f} m, "
        f"{sim.elapsed_s:.1f} s | gap rms {sitl.cross_track_rms_m - sim.cross_track_rms_m:+.3f} m, "
        f"time ×{sitl.elapsed_s / sim.elapsed_s:.2f}  (rms / max / final, true pose)"
    )
