"""Amphibious benchmark: the mode that follows the medium against fixed ROLL and fixed SCROLL,
on the built-in simulator with media by place (the Helix plant).

Courses:

* ``crossing``: bank → 40 m of water → bank, one 60 m leg north (a ``local_ned`` media map
  written by this tool: water from north 10 m to 50 m, hard ground elsewhere);
* ``pond_survey``: ``config/missions/pond-survey.yaml`` (three transects across the pond,
  launched from the south bank, back along the east bank) over
  ``config/maps/pond-media.geojson``;
* ``unmapped_mud``: the same survey with a 10 m × 10 m mud patch on the east bank (north
  10–20 m, east 30–40 m) that only the simulator's map has: helixd flies with the pond's map.

Policies: ``roll`` and ``scroll`` fly the whole mission in that mode (no media map given to
helixd); ``media`` gives helixd the map, so each stretch is flown in its medium's mode
(``helixd.planning.media_modes``) and the ground check switches where the map is wrong
(``helixd.control.ground_check``).

Figures per run (the simulator's truth, sampled every 50 ms of simulated time):

* ``completed``, ``time_s`` (the run's autopilot time), ``fault``;
* ``energy_j``: Σ over the four scrolls of P·dt with P = ``SCROLL_POWER_W`` · |rpm| / max rpm
  (the thesis plots wheel power proportional to wheel rpm; the 100 W at full speed is an
  assumption: the ratios between policies do not depend on it);
* ``rms_m``: per medium (the true map's medium under the rover), the RMS distance of the
  true position from the planned polyline (start → waypoints);
* ``detect_distance_m`` (``unmapped_mud``): how far the rover travelled inside the patch
  before helixd's ``ground_changed`` event (null: never detected, or never entered).

Goals (printed, not asserted): ``media`` completes every course in ≤ 0.75 × fixed SCROLL's
time and with less energy; fixed ROLL's outcome is reported; the patch detected within 2 m.

Usage::

    .venv/bin/python tools/bench_amphibious.py                      # 9 runs, one at a time
    .venv/bin/python tools/bench_amphibious.py --only crossing --policy media
    .venv/bin/python tools/bench_amphibious.py --clock wall --speedup 6   # on the wall clock

Every run flies on the simulated clock by default (:mod:`simflight`: the daemon and the
simulator share one simulated clock in the worker process, the noise seeded), so the figures
are the rover's and the same on any machine; ``--clock wall`` flies the daemon as a
subprocess against the simulator sped up on the wall clock, and the results say so (a loaded
machine then measures itself: 222.6 s instead of 113.1 s on the crossing, stalls).

Results: a table on stdout and ``bench/results/latest.{json,md}`` (section ``amphibious``).
"""

from __future__ import annotations

import concurrent.futures
import itertools
import json
import math
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import typer
import yaml

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # measure the checkout this tool lives in
    sys.path.insert(0, str(ROOT))
if str(ROOT / "tools") not in sys.path:
    sys.path.insert(0, str(ROOT / "tools"))

from bench_results import RESULTS_DIR, write_section  # noqa: E402
from navmetrics import polyline_distance_m  # noqa: E402
from simflight import CLOCK_CHOICES, CLOCK_HELP, clock_label, fly_simulated  # noqa: E402

from helixd.base.frames import latlon_to_ne, ne_to_latlon  # noqa: E402
from helixd.base.media import MediaMap, MediaMapNe  # noqa: E402
from helixd.base.polygon import point_in_polygon  # noqa: E402
from helixd.files.media import read_media_map  # noqa: E402

COURSES = ("crossing", "pond_survey", "unmapped_mud")
POLICIES = ("roll", "scroll", "media")
SURVEY_MISSION = ROOT / "config" / "missions" / "pond-survey.yaml"
POND_MEDIA = ROOT / "config" / "maps" / "pond-media.geojson"
ORIGIN_LATLON = (53.52325, -113.52632)  # the simulator's default EKF origin (the pond's)
# the crossing: water across the course from north 10 m to 50 m, a 60 m leg north
CROSSING_WATER_NE = ((10.0, -30.0), (10.0, 30.0), (50.0, 30.0), (50.0, -30.0))
CROSSING_END_NE = (60.0, 0.0)
# the mud patch the map does not show, on the survey's east-bank leg (north, east m)
PATCH_NE = ((10.0, 30.0), (10.0, 40.0), (20.0, 40.0), (20.0, 30.0))
SCROLL_POWER_W = 100.0  # one scroll at its max rpm (assumed; power ∝ rpm as in the thesis)
TARGET_TIME_RATIO = 0.75
TARGET_DETECT_M = 2.0
SAMPLE_PERIOD_S = 0.05
SAMPLER_WAIT_S = 1.0
KILL_GRACE_S = 15.0
SIM_LIMIT_S = 3000.0  # simulated seconds: a run on the simulated clock still going then hung
# Quicker setup; the staleness watchdogs (wall time) widened so a loaded 2-core machine running
# the simulator sped up does not end a run on a late pose: they judge the machine, not the
# ground. Everything else at its field default.
DAEMON_CONFIG: dict[str, Any] = {
    "startup": {"connect_timeout_s": 20.0, "arm_retry_interval_s": 0.5},
    "safety": {"pose_stale_s": 2.0, "gps_stale_s": 3.0},
}
GROUND_EVENT = re.compile(r"event=ground_changed soft=true .*north_m=(\S+) east_m=(\S+)")


@dataclass(frozen=True)
class Sample:
    t_s: float
    north_m: float
    east_m: float
    rpm: tuple[float, float, float, float]


class Sampler:
    """The simulator's truth (position, scroll rpm) on its own thread, one sample per
    ``SAMPLE_PERIOD_S`` of simulated time while the simulator talks."""

    def __init__(self, wait_for: Callable[..., Any]) -> None:
        self._wait_for = wait_for
        self._stop = threading.Event()
        self.samples: list[Sample] = []
        self._last_ms = -(10**9)
        self._thread = threading.Thread(target=self._run, name="amphibious-truth", daemon=True)

    def take(self, snap: Any) -> bool:
        ms = int(snap.time_boot_ms)
        if ms - self._last_ms >= SAMPLE_PERIOD_S * 1000.0 and not snap.silent:
            self._last_ms = ms
            rpm = tuple(float(r) for r in snap.scroll_rpm)
            self.samples.append(
                Sample(ms / 1000.0, float(snap.north_m), float(snap.east_m), rpm)  # type: ignore[arg-type]
            )
        return self._stop.is_set()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                self._wait_for(self.take, SAMPLER_WAIT_S)
            except TimeoutError:
                continue

    def __enter__(self) -> Sampler:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(timeout=5.0 * SAMPLER_WAIT_S)


# -- the courses --------------------------------------------------------------------------------


@dataclass(frozen=True)
class CourseFiles:
    sim_map: Path  # what the world is
    helixd_map: Path  # what helixd is told (policy media)
    mission: dict[str, Any]  # the mission (YAML data) without mode or media_map
    polyline_ne: list[tuple[float, float]]  # start, then every waypoint (north, east)
    patch_ne: tuple[tuple[float, float], ...] | None = None


def _geojson(features: list[dict[str, Any]], frame: str = "global") -> dict[str, Any]:
    return {
        "type": "FeatureCollection",
        "frame": frame,
        "default_medium": "hard",
        "features": features,
    }


def _feature(medium: str, ring: Sequence[Sequence[float]], name: str) -> dict[str, Any]:
    closed = [list(p) for p in ring] + [list(ring[0])]
    return {
        "type": "Feature",
        "properties": {"medium": medium, "name": name},
        "geometry": {"type": "Polygon", "coordinates": [closed]},
    }


def crossing_files(work: Path) -> CourseFiles:
    ring = [(e, n) for n, e in CROSSING_WATER_NE]  # local_ned GeoJSON: [east, north]
    path = work / "crossing-media.geojson"
    data = _geojson([_feature("water", ring, "40 m of water")], frame="local_ned")
    path.write_text(json.dumps(data), encoding="utf-8")
    n, e = CROSSING_END_NE
    mission = {
        "name": "crossing",
        "frame": "local_ned",
        "waypoints": [{"north": n, "east": e}],
    }
    return CourseFiles(path, path, mission, [(0.0, 0.0), CROSSING_END_NE])


def survey_files(work: Path, patch: bool) -> CourseFiles:
    source = yaml.safe_load(SURVEY_MISSION.read_text(encoding="utf-8"))
    mission = {k: v for k, v in source.items() if k not in ("mode", "media_map")}
    polyline = [(0.0, 0.0)] + [
        latlon_to_ne(w["lat"], w["lon"], *ORIGIN_LATLON) for w in source["waypoints"]
    ]
    if not patch:
        return CourseFiles(POND_MEDIA, POND_MEDIA, mission, polyline)
    data = json.loads(POND_MEDIA.read_text(encoding="utf-8"))
    ring = []
    for n, e in PATCH_NE:
        lat, lon = ne_to_latlon(n, e, *ORIGIN_LATLON)
        ring.append((round(lon, 8), round(lat, 8)))
    data["features"].append(_feature("mud", ring, "mud patch the map does not show"))
    true_map = work / "pond-media-true.geojson"
    true_map.write_text(json.dumps(data), encoding="utf-8")
    return CourseFiles(true_map, POND_MEDIA, mission, polyline, PATCH_NE)


def course_files(course: str, work: Path) -> CourseFiles:
    if course == "crossing":
        return crossing_files(work)
    return survey_files(work, patch=course == "unmapped_mud")


def mission_for(files: CourseFiles, policy: str) -> dict[str, Any]:
    """The mission helixd flies under ``policy``: one mode, or the mode by the map."""
    mission = dict(files.mission)
    if policy == "media":
        mission["mode"] = "scroll"  # where the map says nothing
        mission["media_map"] = str(files.helixd_map.resolve())
    else:
        mission["mode"] = policy
    return mission


# -- the figures (pure) -----------------------------------------------------------------------


def energy_j(samples: Sequence[Sample], max_rpm: float) -> float:
    """Σ over the scrolls of SCROLL_POWER_W · |rpm| / max_rpm · dt (zero-order hold)."""
    total = 0.0
    for a, b in itertools.pairwise(samples):
        dt = b.t_s - a.t_s
        if dt > 0.0:
            total += SCROLL_POWER_W * sum(abs(r) for r in a.rpm) / max_rpm * dt
    return total


def rms_by_medium(
    samples: Sequence[Sample], polyline: Sequence[tuple[float, float]], media: MediaMapNe
) -> dict[str, float]:
    """RMS distance (m) of the true position from the planned polyline, per true medium."""
    sums: dict[str, list[float]] = {}
    for s in samples:
        d = polyline_distance_m(polyline, (s.north_m, s.east_m))
        if math.isfinite(d):
            medium = media.medium_at(s.north_m, s.east_m).value
            sums.setdefault(medium, []).append(d * d)
    return {m: math.sqrt(sum(v) / len(v)) for m, v in sorted(sums.items()) if v}


def detect_distance_m(
    samples: Sequence[Sample],
    patch: Sequence[tuple[float, float]],
    detected_ne: tuple[float, float] | None,
) -> float | None:
    """How far the rover travelled inside ``patch`` before it said so (at ``detected_ne``):
    from its first sample inside to the sample nearest the detection, along its path."""
    if detected_ne is None:
        return None
    inside = [point_in_polygon(s.north_m, s.east_m, patch) for s in samples]
    first = next((i for i, x in enumerate(inside) if x), None)
    if first is None:
        return None
    dn, de = detected_ne
    near = min(
        range(first, len(samples)),
        key=lambda i: math.hypot(samples[i].north_m - dn, samples[i].east_m - de),
    )
    return sum(
        math.hypot(b.north_m - a.north_m, b.east_m - a.east_m)
        for a, b in zip(samples[first:near], samples[first + 1 : near + 1], strict=False)
    )


def detection_from_log(text: str) -> tuple[float, float] | None:
    """Where the daemon's first ``ground_changed`` (soft) event put the rover (north, east)."""
    m = GROUND_EVENT.search(text)
    return None if m is None else (float(m.group(1)), float(m.group(2)))


# -- one run ----------------------------------------------------------------------------------


@dataclass
class RunResult:
    course: str
    policy: str
    completed: bool = False
    time_s: float | None = None
    energy_j: float | None = None
    rms_m: dict[str, float] = field(default_factory=dict)
    detect_distance_m: float | None = None
    fault: str | None = None
    exit_code: int | None = None
    wall_s: float = 0.0
    samples: int = 0
    log_tail: str = ""

    def figures(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "completed": self.completed,
            "time_s": self.time_s,
            "energy_j": self.energy_j,
            "rms_m": self.rms_m,
            "fault": self.fault,
            "exit_code": self.exit_code,
            "wall_s": round(self.wall_s, 1),
            "samples": self.samples,
        }
        if self.course == "unmapped_mud":
            out["detect_distance_m"] = self.detect_distance_m
        return out


def _daemon(cmd: list[str], log_path: Path, cwd: Path, timeout_s: float) -> int | None:
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH")) if p)
    env.pop("NOTIFY_SOCKET", None)
    with log_path.open("w", encoding="utf-8") as log_fh:
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=log_fh, env=env, cwd=cwd)
        try:
            return proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGINT)  # the daemon's own stop path
            try:
                proc.wait(timeout=KILL_GRACE_S)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
            return None


def _fly_on_the_wall(
    sim_cfg: Any, mission_path: Path, root: Path, log_path: Path, timeout_s: float
) -> tuple[int | None, list[Sample]]:
    """Simulator in this process on the wall clock (sped up), the daemon as a subprocess; the
    truth sampled meanwhile on a thread."""
    from helixd.sim.server import start_embedded

    server, url = start_embedded(sim_cfg)
    try:
        cfg = dict(DAEMON_CONFIG, link={"url": url})
        cfg_path = root / "helixd.yaml"
        cfg_path.write_text(yaml.safe_dump(cfg), encoding="utf-8")
        cmd = [
            sys.executable, "-m", "helixd", "run", "--connect", url, "--mission",
            str(mission_path), "--config", str(cfg_path), "--run-dir", str(root / "runs"),
        ]  # fmt: skip
        with Sampler(server.wait_for) as sampler:
            exit_code = _daemon(cmd, log_path, root, timeout_s)
    finally:
        server.stop()
    return exit_code, sampler.samples


def _fly_simulated(
    sim_cfg: Any, mission_path: Path, root: Path, log_path: Path
) -> tuple[int | None, list[Sample]]:
    """The daemon and the simulator on one simulated clock in this process (seeded: the same
    flight on any machine); the truth sampled from every snapshot."""
    cfg_path = root / "helixd.yaml"
    cfg_path.write_text(yaml.safe_dump(DAEMON_CONFIG), encoding="utf-8")
    sampler = Sampler(lambda *_: None)
    exit_code = fly_simulated(
        sim_cfg, mission_path, cfg_path, root / "runs", log_path, sampler.take, SIM_LIMIT_S
    )
    return exit_code, sampler.samples


def run_one(
    course: str,
    policy: str,
    speedup: float,
    timeout_s: float,
    work: Path,
    clock: str = "simulated",
    ground: Path | None = None,
) -> RunResult:
    """One course flown by one policy (``clock``: see :func:`simflight.clock_label`)."""
    import logging

    import structlog

    from helixd.config.vehicle import VehicleConfig
    from helixd.plant.ground import TerrainTable, read_ground_file
    from helixd.sim.sim_config import SimConfig

    structlog.configure(
        wrapper_class=structlog.make_filtering_bound_logger(logging.WARNING),
        logger_factory=structlog.PrintLoggerFactory(sys.stderr),
    )
    root = work / f"{course}-{policy}"
    root.mkdir(parents=True, exist_ok=True)
    files = course_files(course, root)
    mission_path = root / "mission.yaml"
    mission_path.write_text(yaml.safe_dump(mission_for(files, policy)), encoding="utf-8")
    true_map: MediaMap = read_media_map(files.sim_map)
    terrains = TerrainTable() if ground is None else read_ground_file(ground)  # --sim-ground
    sim_cfg = SimConfig(
        speedup=speedup, noise="low", seed=1, plant="helix", media=true_map, terrains=terrains
    )
    log_path = root / "daemon.log"
    t0 = time.monotonic()
    if clock == "simulated":
        exit_code, samples = _fly_simulated(sim_cfg, mission_path, root, log_path)
    else:
        exit_code, samples = _fly_on_the_wall(sim_cfg, mission_path, root, log_path, timeout_s)
    wall_s = time.monotonic() - t0
    result = RunResult(course, policy, exit_code=exit_code, wall_s=wall_s)
    result.samples = len(samples)
    log_text = log_path.read_text(encoding="utf-8", errors="replace")
    result.log_tail = " | ".join(log_text.splitlines()[-2:])
    runs = sorted(p for p in (root / "runs").glob("*") if p.is_dir())
    if runs:
        try:
            summary = json.loads((runs[-1] / "summary.json").read_text(encoding="utf-8"))
            result.completed = bool(summary.get("completed"))
            result.time_s = summary.get("duration_s")
            result.fault = summary.get("fault")
        except (OSError, ValueError):
            pass
    if samples:
        result.energy_j = energy_j(samples, VehicleConfig().max_rpm)
        placed = true_map.to_ne(ORIGIN_LATLON)
        result.rms_m = rms_by_medium(samples, files.polyline_ne, placed)
    if files.patch_ne is not None:
        result.detect_distance_m = detect_distance_m(
            samples, files.patch_ne, detection_from_log(log_text)
        )
    return result


# -- the verdict (pure) ---------------------------------------------------------------------------


def verdicts(section: dict[str, dict[str, dict[str, Any]]]) -> list[str]:
    """One line per goal: met or missed, with the figures."""
    lines: list[str] = []
    for course, cell in section.items():
        media, scroll, roll = cell.get("media"), cell.get("scroll"), cell.get("roll")
        if media is not None and scroll is not None:
            t_m, t_s = media.get("time_s"), scroll.get("time_s")
            e_m, e_s = media.get("energy_j"), scroll.get("energy_j")
            ratio = t_m / t_s if t_m and t_s else None
            ok_t = bool(media.get("completed")) and ratio is not None
            ok_t = ok_t and ratio <= TARGET_TIME_RATIO  # type: ignore[operator]
            ok_e = e_m is not None and e_s is not None and e_m < e_s
            lines.append(
                f"{course}: media {'completed' if media.get('completed') else 'NOT completed'}, "
                f"time {_n(t_m)} s vs scroll {_n(t_s)} s (ratio {_n(ratio, '.2f')}, goal "
                f"<= {TARGET_TIME_RATIO}: {'met' if ok_t else 'MISSED'}), energy {_n(e_m)} J vs "
                f"{_n(e_s)} J ({'less: met' if ok_e else 'NOT less: MISSED'})"
            )
        if roll is not None:
            how = "completed" if roll.get("completed") else f"stopped ({roll.get('fault')})"
            lines.append(f"{course}: fixed roll {how} after {_n(roll.get('time_s'))} s")
        if media is not None and course == "unmapped_mud":
            d = media.get("detect_distance_m")
            met = d is not None and d <= TARGET_DETECT_M
            lines.append(
                f"{course}: patch detected after {_n(d, '.2f')} m inside it (goal <= "
                f"{TARGET_DETECT_M} m: {'met' if met else 'MISSED'})"
            )
    return lines


def _n(value: Any, spec: str = ".0f") -> str:
    return "-" if value is None else format(value, spec)


def table(results: Sequence[RunResult]) -> str:
    head = f"{'course':<13} {'policy':<7} {'done':<5} {'time_s':>7} {'energy_j':>9}  rms_m"
    rows = [head]
    for r in results:
        rms = ", ".join(f"{m} {v:.2f}" for m, v in r.rms_m.items())
        extra = f"  detect {_n(r.detect_distance_m, '.2f')} m" if r.course == "unmapped_mud" else ""
        rows.append(
            f"{r.course:<13} {r.policy:<7} {'yes' if r.completed else 'no':<5} "
            f"{_n(r.time_s, '.1f'):>7} {_n(r.energy_j):>9}  {rms}{extra}"
            + ("" if r.completed else f"  ({r.fault or 'no run'})")
        )
    return "\n".join(rows)


def main(
    clock: str = typer.Option("simulated", help=CLOCK_HELP),
    speedup: float = typer.Option(
        6.0, min=0.5, max=20.0, help="simulator speed-up (--clock wall only)"
    ),
    only: list[str] = typer.Option([], help="courses to fly (default: all)"),  # noqa: B008
    policy: list[str] = typer.Option([], help="policies (default: roll, scroll, media)"),  # noqa: B008
    jobs: int = typer.Option(1, min=1, max=8, help="runs at once"),
    timeout_s: float = typer.Option(
        600.0, min=10.0, help="wall-time limit of one run (s; --clock wall only)"
    ),
    results_dir: Path = typer.Option(RESULTS_DIR, help="where latest.json/md go"),  # noqa: B008
    sim_ground: Path | None = typer.Option(  # noqa: B008
        None, help="the simulator's ground file (helixd run --sim-ground's format)"
    ),
) -> None:
    courses = [c for c in COURSES if not only or c in only]
    policies = [p for p in POLICIES if not policy or p in policy]
    unknown = sorted(set(only) - set(COURSES)) + sorted(set(policy) - set(POLICIES))
    if clock not in CLOCK_CHOICES:
        unknown.append(f"--clock {clock}")
    if unknown or not courses or not policies:
        typer.echo(f"unknown or empty selection: {unknown}; courses {COURSES}, policies {POLICIES}")
        raise typer.Exit(2)
    combos = [(c, p) for c in courses for p in policies]
    label = clock_label(clock, speedup)
    typer.echo(f"amphibious: {len(combos)} runs, {label}, {jobs} worker(s)")
    with tempfile.TemporaryDirectory(prefix="bench-amphibious-") as tmp:
        work = Path(tmp)
        results: list[RunResult] = []
        with concurrent.futures.ProcessPoolExecutor(max_workers=jobs) as pool:
            futures = [
                pool.submit(run_one, c, p, speedup, timeout_s, work, clock, sim_ground)
                for c, p in combos
            ]
            for fut in futures:
                results.append(fut.result())
    results.sort(key=lambda r: (COURSES.index(r.course), POLICIES.index(r.policy)))
    section: dict[str, Any] = {}
    for r in results:
        section.setdefault(r.course, {})[r.policy] = r.figures()
    lines = verdicts(section)
    typer.echo(f"clock: {label}")
    typer.echo(table(results))
    for line in lines:
        typer.echo(line)
    write_section(
        "amphibious",
        {
            **section,
            "verdicts": lines,
            "clock": clock,
            "clock_note": label,
            "speedup": speedup if clock == "wall" else None,
            "energy_model": f"{SCROLL_POWER_W:g} W per scroll at max rpm, power ∝ |rpm|",
        },
        results_dir,
    )
    typer.echo(f"results: {results_dir / 'latest.json'}")
    if any(r.samples == 0 for r in results):
        typer.echo("a run measured nothing (no samples)")
        raise typer.Exit(1)


if __name__ == "__main__":
    typer.run(main)
