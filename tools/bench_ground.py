"""Ground benchmark: the rover learns its ground from its own runs and plans with it.

For each truth (a ground file for the simulator, ``--truth FILE``, repeatable; by default the
bench's own two, which differ from the built-in table): the pond survey
(``config/missions/pond-survey.yaml`` over ``config/maps/pond-media.geojson``) flown three
times in a row by ``helixd run --sim --sim-clock simulated`` (the built-in simulator on the
simulated clock: the real CLI, real UDP, no wall clock in any figure), from an empty ground
profile, learning on, the profile carried from run to run, ``media.modes: learned``.

Figures (section ``ground`` of the results JSON, per truth file stem):

* ``runs``: in order, each ``completed``, ``time_s`` (summary.json's autopilot time),
  ``estimate_s`` (what ``helixd check`` printed before that run, with the profile as it was)
  and ``energy_j`` (Σ over the four scrolls of the truth's ``power_w`` of the medium under the
  scroll × |scroll fraction sent| × Δt, over flight.csv);
* ``learned_max_rel_error``: after run 1, the largest |learned − truth| / truth over every
  medium × mode flown at least 20 m, each on the axis that mode drives;
* ``policy``: per medium the survey crosses, ``picked`` (the mode ``media.modes: learned``
  picks before run 3) and ``fastest`` (the mode the truth makes fastest: of ROLL and SCROLL,
  the one whose axis delivers most of the command through the slip feed-forward).

Goals (printed, not asserted): learned_max_rel_error ≤ 0.10; run 3's estimate within 5 % of
its time (run 1's error stated beside it); picked = fastest for every medium crossed.

Usage::

    .venv/bin/python tools/bench_ground.py                       # the bench's two truths
    .venv/bin/python tools/bench_ground.py --truth site.yaml --results-dir /tmp/r
"""

from __future__ import annotations

import itertools
import json
import math
import os
import re
import subprocess
import sys
import tempfile
from collections.abc import Mapping, Sequence
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

from helixd.base.frames import latlon_to_ne  # noqa: E402
from helixd.base.media import Medium, media_along  # noqa: E402
from helixd.base.plan import MotionMode  # noqa: E402
from helixd.config.root import HelixdConfig  # noqa: E402
from helixd.config.vehicle import VehicleConfig  # noqa: E402
from helixd.control.ground_fit import DRIVEN, SCROLL_CORNERS  # noqa: E402
from helixd.files.media import read_media_map  # noqa: E402
from helixd.planning.media_modes import MODE_AXIS, delivered  # noqa: E402
from helixd.plant.ground import TerrainTable, read_ground_file  # noqa: E402
from helixd.prepare.ground_learning import learned_policy_modes  # noqa: E402
from helixd.recorder.ground_profile import read_profile, run_origin  # noqa: E402
from helixd.recorder.rows import read_flight_columns  # noqa: E402

SURVEY = ROOT / "config" / "missions" / "pond-survey.yaml"
POND = ROOT / "config" / "maps" / "pond-media.geojson"
RUNS = 3
MIN_METRES = 20.0
GOAL_REL_ERROR = 0.10
GOAL_ESTIMATE = 0.05
RUN_TIMEOUT_S = 1800.0
ESTIMATE = re.compile(r"^estimate: (\d+(?:\.\d+)?) s", re.MULTILINE)
# the bench's own truths: sites that differ from the built-in table (docs/physics.md)
TRUTHS: dict[str, dict[str, dict[str, float]]] = {
    "soft-site": {  # wetter than the table: everything slips more
        "hard": {"roll_efficiency": 0.8, "yaw_efficiency": 0.7},
        "mud": {"roll_efficiency": 0.25, "scroll_efficiency": 0.65, "yaw_efficiency": 0.45},
        "water": {"scroll_efficiency": 0.5, "yaw_efficiency": 0.35, "power_w": 90.0},
    },
    "slick-site": {  # a slick bank, a pond that pushes back harder
        "hard": {"roll_efficiency": 0.7, "scroll_efficiency": 0.2, "yaw_efficiency": 0.6},
        "mud": {"roll_efficiency": 0.4, "scroll_efficiency": 0.9, "power_w": 120.0},
        "water": {"roll_efficiency": 0.08, "scroll_efficiency": 0.75, "yaw_efficiency": 0.5},
    },
}
# The ground check (media.detect) is off: the map is the truth's own, and on a site whose
# hard ground rolls 0.7 (slick-site) the check, judging 1.5 m windows of commanded travel from
# standstill, took ROLL for soft and SCROLL for firm in turn at every stop (a dozen changes of
# mode per waypoint, 125 s of turns in place in a 742 s survey): a finding for the check, not
# something the profile can learn (docs/measurements.md, "Learning the ground").
DAEMON_CONFIG: dict[str, Any] = {
    "startup": {"connect_timeout_s": 20.0, "arm_retry_interval_s": 0.5},
    "media": {"modes": "learned", "detect": False},
}


def truth_files(given: Sequence[Path], work: Path) -> list[Path]:
    """The truths to fly: ``given``, else the bench's own written into ``work``."""
    if given:
        return list(given)
    out = []
    for name, table in TRUTHS.items():
        path = work / f"{name}.yaml"
        path.write_text(yaml.safe_dump(table), encoding="utf-8")
        out.append(path)
    return out


def survey_mission(work: Path) -> Path:
    """The pond survey with its media map made absolute (the mission is copied)."""
    data = yaml.safe_load(SURVEY.read_text(encoding="utf-8"))
    data["media_map"] = str(POND)
    path = work / "pond-survey.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


def fastest(truth: TerrainTable, cfg: HelixdConfig) -> dict[Medium, MotionMode]:
    """Per medium the mode the truth makes fastest (delivered through the feed-forward; ties
    to the larger fraction, as the learned policy breaks them)."""
    slip = cfg.control.slip
    out = {}
    for medium in Medium:
        row = truth.get(medium)
        f = {"roll": row.roll_efficiency, "scroll": row.scroll_efficiency}
        out[medium] = max(
            MODE_AXIS,
            key=lambda m: (
                delivered(f[MODE_AXIS[m]], slip.max_gain, slip.stuck_fraction)
                + 1e-6 * f[MODE_AXIS[m]]
            ),
        )
    return out


def crossed_media(mission: Path) -> list[Medium]:
    """The media the survey's path crosses (the pond's map, placed at the mission's start)."""
    data = yaml.safe_load(mission.read_text(encoding="utf-8"))
    pts = [(w["lat"], w["lon"]) for w in data["waypoints"]]
    placed = read_media_map(POND).to_ne(pts[0])
    ne = [latlon_to_ne(lat, lon, *pts[0]) for lat, lon in pts]
    seen: list[Medium] = []
    for a, b in itertools.pairwise(ne):
        for run in media_along(placed, a, b):
            if run.medium not in seen:
                seen.append(run.medium)
    return seen


def energy_j(run_dir: Path, truth: TerrainTable) -> float | None:
    """Σ over the scrolls of the truth's power of the medium under each × |fraction| × Δt."""
    csv = run_dir / "flight.csv"
    if not csv.is_file():
        return None
    c = read_flight_columns(csv)
    placed = read_media_map(POND).to_ne(run_origin(run_dir))
    vehicle = VehicleConfig()
    total = 0.0
    t = c["t_boot_s"]
    for i in range(1, len(t)):
        dt = float(t[i] - t[i - 1])
        if not 0.0 < dt <= 0.5 or not bool(c["armed"][i]):
            continue
        n, e, psi = float(c["north_m"][i]), float(c["east_m"][i]), float(c["yaw_ned_rad"][i])
        cs, sn = math.cos(psi), math.sin(psi)
        for j, (fx, fy) in enumerate(SCROLL_CORNERS):
            x, y = fx * vehicle.lx_m, fy * vehicle.ly_m
            medium = placed.medium_at(n + x * cs + y * sn, e + x * sn - y * cs)
            f = float(c[f"scroll{j + 1}"][i])
            if math.isfinite(f):
                total += truth.get(medium).power_w * abs(f) * dt
    return total


def learned_max_rel_error(profile: Path, truth: TerrainTable) -> float | None:
    """The largest relative error of a learnt driven-axis fraction (≥ MIN_METRES flown)."""
    worst: float | None = None
    for (medium, mode), cell in read_profile(profile).cells.items():
        if cell.metres < MIN_METRES:
            continue
        row = truth.get(medium)
        for axis in DRIVEN[mode]:
            got = cell.axis(axis).fraction
            true = row.roll_efficiency if axis == "roll" else row.scroll_efficiency
            if got is None or true <= 0.0:
                continue
            err = abs(got - true) / true
            worst = err if worst is None else max(worst, err)
    return worst


def _helixd(args: list[str], timeout_s: float) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH")) if p)
    env.pop("NOTIFY_SOCKET", None)
    return subprocess.run(
        [sys.executable, "-m", "helixd", *args],
        capture_output=True,
        text=True,
        timeout=timeout_s,
        env=env,
        check=False,
    )


def fly_truth(truth_path: Path, work: Path, seed0: int) -> dict[str, Any]:
    """The survey flown RUNS times over one truth, from an empty profile."""
    name = truth_path.stem
    root = work / name
    root.mkdir(parents=True, exist_ok=True)
    truth = read_ground_file(truth_path)
    mission = survey_mission(root)
    profile = root / "ground-profile.yaml"
    cfg_data = {**DAEMON_CONFIG, "ground": {"profile_file": str(profile)}}
    cfg_path = root / "helixd.yaml"
    cfg_path.write_text(yaml.safe_dump(cfg_data), encoding="utf-8")
    cfg = HelixdConfig.model_validate(cfg_data)
    runs: list[dict[str, Any]] = []
    section: dict[str, Any] = {"runs": runs}
    for k in range(1, RUNS + 1):
        if k == RUNS:
            picks = learned_policy_modes(cfg)
            truth_best = fastest(truth, cfg)
            section["policy"] = {
                m.value: {"picked": picks[m].value, "fastest": truth_best[m].value}
                for m in crossed_media(mission)
            }
        check = _helixd(["check", "--mission", str(mission), "--config", str(cfg_path)], 300.0)
        m = ESTIMATE.search(check.stdout + check.stderr)
        before = {p.name for p in (root / "runs").glob("*")} if (root / "runs").is_dir() else set()
        flown = _helixd(
            [
                "run",
                "--sim",
                "--sim-clock",
                "simulated",
                "--sim-seed",
                str(seed0 + k),
                "--sim-noise",
                "low",
                "--sim-media",
                str(POND),
                "--sim-ground",
                str(truth_path),
                "--mission",
                str(mission),
                "--config",
                str(cfg_path),
                "--run-dir",
                str(root / "runs"),
                "--log-level",
                "warning",
            ],
            RUN_TIMEOUT_S,
        )
        new = sorted(p for p in (root / "runs").glob("*") if p.is_dir() and p.name not in before)
        figures: dict[str, Any] = {
            "completed": False,
            "time_s": None,
            "estimate_s": float(m.group(1)) if m else None,
            "energy_j": None,
        }
        if new:
            summary = json.loads((new[-1] / "summary.json").read_text(encoding="utf-8"))
            figures["completed"] = bool(summary.get("completed"))
            figures["time_s"] = summary.get("duration_s")
            e = energy_j(new[-1], truth)
            figures["energy_j"] = None if e is None else round(e, 0)
        else:
            figures["error"] = (flown.stderr or "")[-500:]
        runs.append(figures)
        typer.echo(f"{name} run {k}: {figures} (exit {flown.returncode})")
        if k == 1:
            section["learned_max_rel_error"] = learned_max_rel_error(profile, truth)
    return section


def verdicts(section: Mapping[str, Mapping[str, Any]]) -> list[str]:
    lines: list[str] = []
    for name, cell in section.items():
        err = cell.get("learned_max_rel_error")
        ok = err is not None and err <= GOAL_REL_ERROR
        lines.append(
            f"{name}: learned_max_rel_error {_n(err, '.3f')} (goal <= {GOAL_REL_ERROR}: "
            f"{'met' if ok else 'MISSED'})"
        )
        runs = cell.get("runs", [])
        rel = [
            None
            if not (r.get("time_s") and r.get("estimate_s"))
            else (r["estimate_s"] - r["time_s"]) / r["time_s"]
            for r in runs
        ]
        if len(rel) == RUNS:
            ok = rel[-1] is not None and abs(rel[-1]) <= GOAL_ESTIMATE
            lines.append(
                f"{name}: run {RUNS} estimate {_n(runs[-1].get('estimate_s'))} s vs "
                f"{_n(runs[-1].get('time_s'), '.1f')} s ({_n(rel[-1], '+.1%')}; goal within "
                f"{GOAL_ESTIMATE:.0%}: {'met' if ok else 'MISSED'}); run 1 {_n(rel[0], '+.1%')}"
            )
        policy = cell.get("policy", {})
        wrong = [m for m, p in policy.items() if p.get("picked") != p.get("fastest")]
        lines.append(
            f"{name}: policy picked the fastest mode in {len(policy) - len(wrong)}/{len(policy)} "
            f"media crossed ({'met' if policy and not wrong else 'MISSED: ' + ', '.join(wrong)})"
        )
    return lines


def _n(value: Any, spec: str = ".0f") -> str:
    return "-" if value is None else format(value, spec)


def main(
    truth: list[Path] = typer.Option([], help="ground file of a truth (repeatable)"),  # noqa: B008
    results_dir: Path = typer.Option(RESULTS_DIR, help="where latest.json/md go"),  # noqa: B008
    seed: int = typer.Option(40, min=0, help="the simulator's noise seed of run 1 (then +1)"),
) -> None:
    with tempfile.TemporaryDirectory(prefix="bench-ground-") as tmp:
        work = Path(tmp)
        files = truth_files(truth, work)
        typer.echo(f"ground: {len(files)} truth(s) x {RUNS} runs of the pond survey")
        section = {path.stem: fly_truth(path, work, seed) for path in files}
    lines = verdicts(section)
    for line in lines:
        typer.echo(line)
    write_section(
        "ground",
        {**section, "verdicts": lines, "clock": "simulated (run --sim --sim-clock simulated)"},
        results_dir,
    )
    typer.echo(f"results: {results_dir / 'latest.json'}")
    if any(not r.get("completed") for cell in section.values() for r in cell["runs"]):
        raise typer.Exit(1)


if __name__ == "__main__":
    typer.run(main)
