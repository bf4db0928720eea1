"""Navigation benchmark: does the line-tracking guidance beat the thesis baseline?

Matrix (default): missions square/hexagon/circle × modes roll/scroll/omni × terrains hard and
mud × guidance line/thesis × seeds 1..3, thesis pose noise. ROLL runs on hard ground only: the
simulator's terrain table gives ROLL 30 % of its speed in mud and digs a pit on slip (the
thesis: ROLL works on hard ground and grass), so roll-in-mud measures the terrain, not the
guidance (``--roll-anywhere`` runs it anyway).

Each run starts the built-in simulator in the worker process (:func:`helixd.sim.start_embedded`)
and the real daemon as a subprocess (``python -m helixd run --connect …``), exactly as
``tests/integration/harness.py`` does. While the daemon flies, a thread samples the
simulator's TRUE pose from its snapshots; afterwards the planned legs are put into NED with the
mission frame the daemon recorded in ``flight.csv`` and the true path is measured against them
(:mod:`navmetrics`): cross-track RMS/max, final error. Beside them: the estimated-pose figures
from ``summary.json``, autopilot time and scroll effort (∫ Σ|fraction| dt from ``flight.csv``).

Guidance is passed to the daemon as ``{"control": {"guidance": …}}`` only when it is not the
daemon's default; a daemon that does not know the key is detected up front (and from exit
code 2 with "unknown key") and reported, its runs skipped.

Usage::

    .venv/bin/python tools/bench_navigation.py                       # 90 runs, 2 workers
    .venv/bin/python tools/bench_navigation.py --only square/roll --guidance thesis --runs 1
    .venv/bin/python tools/bench_navigation.py --only circle --only omni/mud --jobs 1

Results: a table on stdout and ``bench/results/latest.{json,md}`` (section ``navigation``).
"""

from __future__ import annotations

import concurrent.futures
import json
import math
import multiprocessing
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import typer
import yaml

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # measure the checkout this tool lives in
    sys.path.insert(0, str(ROOT))
if str(ROOT / "tools") not in sys.path:
    sys.path.insert(0, str(ROOT / "tools"))

import navmetrics  # noqa: E402 - after the path set-up above
from bench_results import write_section  # noqa: E402

from helixd.files.yamlio import parse_yaml_text  # noqa: E402

MISSIONS_DIR = ROOT / "config" / "missions"
MISSIONS = ("square", "hexagon", "circle")
MODES = ("roll", "scroll", "omni")
TERRAINS = ("hard", "grass", "sand", "mud")
DEFAULT_TERRAINS = ("hard", "mud")
# ROLL is not flown on these unless --roll-anywhere (see the module docstring).
NO_ROLL_TERRAINS = frozenset({"mud", "sand"})
GUIDANCES = ("line", "thesis")
BASELINE = "thesis"
NEW = "line"
NOISES = ("none", "low", "thesis")
# Targets printed next to the figures (not asserted).
TARGET_RMS_RATIO = 0.5  # new RMS at most half the baseline's, every cell
TARGET_TIME_RATIO = 1.10  # no run more than 10 % slower than the baseline (same seed)
TARGET_TEXT = (
    f"RMS ratio <= {TARGET_RMS_RATIO:g} in every cell and no run slower than the baseline by "
    f"more than {100 * (TARGET_TIME_RATIO - 1):.0f} % (same seed)"
)
# Daemon settings for the benchmark: quicker setup, everything else at its field default.
DAEMON_CONFIG: dict[str, Any] = {
    "safety": {"connect_timeout_s": 20.0, "arm_retry_interval_s": 0.5},
}
KILL_GRACE_S = 15.0
LOG_TAIL_LINES = 3
FLIGHT_COLUMNS = (
    "t_boot_s", "north_m", "east_m", "yaw_ned_rad", "x_m", "y_m", "yaw_rad",
    "scroll1", "scroll2", "scroll3", "scroll4",
)  # fmt: skip
TRUE_POSE_PERIOD_S = 0.02  # sample the true pose every 20 ms of simulated time
SAMPLER_WAIT_S = 1.0
UNKNOWN_KEY_MARK = "unknown key"


@dataclass(frozen=True)
class Combo:
    mission: str
    mode: str
    terrain: str
    guidance: str = BASELINE

    @property
    def label(self) -> str:
        return f"{self.mission}/{self.mode}/{self.terrain}/{self.guidance}"

    @property
    def cell(self) -> tuple[str, str, str]:
        return (self.mission, self.mode, self.terrain)


@dataclass
class RunResult:
    combo: Combo
    seed: int
    completed: bool
    reached: int
    total: int
    xt_rms_m: float | None  # TRUE pose vs the planned legs
    xt_max_m: float | None
    final_error_m: float | None
    est_xt_rms_m: float | None  # what the daemon saw (summary.json)
    est_xt_max_m: float | None
    est_final_error_m: float | None
    time_s: float | None  # autopilot (simulated) time, first to last control step
    effort: float | None  # ∫ Σ|scroll fraction| dt (fraction-seconds)
    wall_s: float  # the daemon process, start to exit
    exit_code: int | None  # None: killed after the timeout
    fault: str | None
    true_samples: int = 0
    refused: bool = False  # the daemon refused the guidance key (unknown key)


# -- pure helpers -----------------------------------------------------------------------------


def parse_terrains(specs: Sequence[str]) -> tuple[str, ...]:
    """Terrain names (each once, in the given order); ValueError on an unknown one."""
    out: list[str] = []
    for spec in specs:
        if spec not in TERRAINS:
            raise ValueError(f"--terrain {spec!r}: expected one of {', '.join(TERRAINS)}")
        if spec not in out:
            out.append(spec)
    return tuple(out) or DEFAULT_TERRAINS


def parse_guidances(specs: Sequence[str]) -> tuple[str, ...]:
    out: list[str] = []
    for spec in specs:
        if spec not in GUIDANCES:
            raise ValueError(f"--guidance {spec!r}: expected one of {', '.join(GUIDANCES)}")
        if spec not in out:
            out.append(spec)
    return tuple(out) or GUIDANCES


def _matches(spec: str, combo: Combo) -> bool:
    """``spec`` is a mission, mode or terrain, or ``/``-joined names, each of which must match."""
    fields = (combo.mission, combo.mode, combo.terrain)
    return all(part in fields for part in spec.split("/"))


def select_combos(
    only: Sequence[str],
    terrains: Sequence[str] = DEFAULT_TERRAINS,
    guidances: Sequence[str] = (BASELINE,),
    roll_anywhere: bool = False,
) -> list[Combo]:
    """Mission × mode × terrain × guidance runs matching any ``only`` filter (all when empty).

    A filter is a mission (``square``), a mode (``roll``), a terrain (``mud``), or several
    joined by ``/`` that must all match (``square/roll``, ``omni/mud``, ``circle/scroll/hard``).
    ROLL is left out on mud and sand unless ``roll_anywhere``. ValueError on a filter that
    matches nothing.
    """
    combos = [
        Combo(m, mode, terrain, g)
        for m in MISSIONS
        for mode in MODES
        for terrain in terrains
        if roll_anywhere or mode != "roll" or terrain not in NO_ROLL_TERRAINS
        for g in guidances
    ]
    if not only:
        return combos
    for spec in only:
        if not any(_matches(spec, c) for c in combos):
            raise ValueError(
                f"--only {spec!r}: expected a mission ({', '.join(MISSIONS)}), a mode "
                f"({', '.join(MODES)}), a terrain ({', '.join(terrains)}) or "
                "several of them joined by / (square/roll, omni/mud) present in the matrix"
            )
    return [c for c in combos if any(_matches(spec, c) for spec in only)]


def mission_with_mode(mission_yaml: str, mode: str) -> str:
    """The mission file's text with its motion mode replaced (comments are dropped)."""
    data = parse_yaml_text(mission_yaml)
    if not isinstance(data, dict):
        raise ValueError("a mission file is a YAML mapping")
    data["mode"] = mode
    return yaml.safe_dump(data, sort_keys=False)


def default_guidance() -> str:
    """The daemon's default ``control.guidance`` (the thesis law when it has no such key)."""
    from helixd.config import ControlConfig

    field = ControlConfig.model_fields.get("guidance")
    if field is None:
        return BASELINE
    value = field.default
    return str(getattr(value, "value", value))


def daemon_config(guidance: str, default: str) -> dict[str, Any]:
    """The benchmark's daemon config; guidance only when it is not the daemon's default."""
    cfg: dict[str, Any] = {k: dict(v) for k, v in DAEMON_CONFIG.items()}
    if guidance != default:
        cfg.setdefault("control", {})["guidance"] = guidance
    return cfg


def guidance_refusal(guidance: str, default: str) -> str | None:
    """None if this checkout's config model accepts the guidance; else why not (one line)."""
    from pydantic import ValidationError

    from helixd.config import HelixdConfig
    from helixd.files.models import format_validation_error

    try:
        HelixdConfig.model_validate(daemon_config(guidance, default))
    except ValidationError as exc:
        return "; ".join(format_validation_error("benchmark config", exc, HelixdConfig))
    return None


def autopilot_duration_s(flight_csv: str) -> float | None:
    """Last minus first ``t_boot_s`` of a flight.csv (None with fewer than two rows)."""
    rows = [ln for ln in flight_csv.splitlines() if ln and not ln.startswith("#")]
    if len(rows) < 3 or not rows[0].startswith("t_boot_s,"):
        return None
    try:
        first = float(rows[1].split(",", 1)[0])
        last = float(rows[-1].split(",", 1)[0])
    except ValueError:
        return None
    return last - first


@dataclass(frozen=True)
class TrueFigures:
    """Figures from flight.csv and the simulator's true-pose samples."""

    xt_rms_m: float | None = None
    xt_max_m: float | None = None
    final_error_m: float | None = None
    time_s: float | None = None
    effort: float | None = None
    samples: int = 0


def true_figures(
    columns: dict[str, Sequence[float]],
    waypoints_xy_m: Sequence[tuple[float, float]],
    samples: Sequence[tuple[float, float, float]],
) -> TrueFigures:
    """Metrics of the true path against the planned legs.

    ``columns``: flight.csv columns (t_boot_s, north_m, east_m, yaw_ned_rad, x_m, y_m, yaw_rad,
    scroll1..4); ``waypoints_xy_m``: the plan in the mission frame; ``samples``: the
    simulator's true pose as (t_boot_s, north_m, east_m). The planned legs start at the first
    recorded mission-frame pose (the navigator's first leg starts where the rover stands).
    """
    t = list(columns.get("t_boot_s", ()))
    finite_t = [v for v in t if math.isfinite(v)]
    if len(finite_t) < 2:
        return TrueFigures()
    t_first, t_last = finite_t[0], finite_t[-1]
    scrolls = [list(columns[f"scroll{i}"]) for i in range(1, 5) if f"scroll{i}" in columns]
    effort = navmetrics.scroll_effort(t, scrolls) if len(scrolls) == 4 else None
    frame = navmetrics.frame_from_flight(
        *(columns[k] for k in ("north_m", "east_m", "yaw_ned_rad", "x_m", "y_m", "yaw_rad"))
    )
    start = next(
        (
            (x, y)
            for x, y in zip(columns["x_m"], columns["y_m"], strict=True)
            if math.isfinite(x) and math.isfinite(y)
        ),
        None,
    )
    if frame is None or start is None or not waypoints_xy_m:
        return TrueFigures(time_s=t_last - t_first, effort=effort)
    poly = navmetrics.planned_polyline_ned(frame, start, waypoints_xy_m)
    path = navmetrics.clip_to_window(samples, t_first, t_last)
    m = navmetrics.path_metrics(path, poly)
    return TrueFigures(
        xt_rms_m=m.xt_rms_m,
        xt_max_m=m.xt_max_m,
        final_error_m=m.final_error_m,
        time_s=t_last - t_first,
        effort=effort,
        samples=m.samples,
    )


def result_from_summary(
    combo: Combo,
    seed: int,
    summary: dict[str, Any] | None,
    figures: TrueFigures,
    wall_s: float,
    exit_code: int | None,
    log_tail: str,
) -> RunResult:
    """One benchmark row from ``summary.json`` (None when the daemon wrote none)."""
    refused = exit_code == 2 and UNKNOWN_KEY_MARK in log_tail
    if summary is None:
        why = "daemon refused its config" if refused else "no summary.json"
        return RunResult(
            combo, seed, False, 0, 0, figures.xt_rms_m, figures.xt_max_m,
            figures.final_error_m, None, None, None, figures.time_s, figures.effort, wall_s,
            exit_code, f"{why}; daemon log: {log_tail or '(empty)'}", figures.samples, refused,
        )  # fmt: skip
    fault = summary.get("fault")
    if exit_code is None:
        fault = f"timed out and killed ({fault})" if fault else "timed out and killed"
    return RunResult(
        combo=combo,
        seed=seed,
        completed=bool(summary.get("completed")) and exit_code == 0,
        reached=int(summary.get("waypoints_reached", 0)),
        total=int(summary.get("waypoints_total", 0)),
        xt_rms_m=figures.xt_rms_m,
        xt_max_m=figures.xt_max_m,
        final_error_m=figures.final_error_m,
        est_xt_rms_m=_opt_float(summary.get("cross_track_rms_m")),
        est_xt_max_m=_opt_float(summary.get("cross_track_max_m")),
        est_final_error_m=_opt_float(summary.get("final_error_m")),
        time_s=figures.time_s,
        effort=figures.effort,
        wall_s=wall_s,
        exit_code=exit_code,
        fault=None if fault is None else str(fault),
        true_samples=figures.samples,
        refused=refused,
    )


def _opt_float(value: object) -> float | None:
    if isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value):
        return float(value)
    return None


def _num(value: float | None, spec: str = ".2f") -> str:
    return "-" if value is None else format(value, spec)


def mean_worst(values: Sequence[float | None]) -> dict[str, float | None]:
    """Mean and worst (max) of the present values; both None if none is."""
    got = [v for v in values if v is not None]
    if not got:
        return {"mean": None, "worst": None}
    return {"mean": statistics.fmean(got), "worst": max(got)}


FIGURES = ("xt_rms_m", "xt_max_m", "final_error_m", "time_s", "effort",
           "est_xt_rms_m", "est_xt_max_m", "est_final_error_m")  # fmt: skip


def aggregate(results: Sequence[RunResult]) -> list[dict[str, Any]]:
    """Per mission × mode × terrain × guidance over seeds: completed k/n, mean/worst figures.

    Figures of runs that did not complete are included (a failed run is not hidden); the
    ``completed`` count says how many there are.
    """
    by_combo: dict[Combo, list[RunResult]] = {}
    for r in results:
        by_combo.setdefault(r.combo, []).append(r)
    cells: list[dict[str, Any]] = []
    for combo, rs in by_combo.items():
        cell: dict[str, Any] = {
            "mission": combo.mission,
            "mode": combo.mode,
            "terrain": combo.terrain,
            "guidance": combo.guidance,
            "completed": f"{sum(r.completed for r in rs)}/{len(rs)}",
            "seeds": [r.seed for r in rs],
        }
        for name in FIGURES:
            cell[name] = mean_worst([getattr(r, name) for r in rs])
        cells.append(cell)
    return cells


def compare(
    results: Sequence[RunResult], new: str = NEW, baseline: str = BASELINE
) -> list[dict[str, Any]]:
    """Per mission × mode × terrain with both guidances: new / baseline ratios and a verdict.

    ``rms_ratio``: mean true RMS of new ÷ that of the baseline (``est_rms_ratio``: the same on
    the pose the daemon saw, beside it: with thesis noise the true RMS has a floor of roughly
    the estimate's drift, ~0.5 m, that no guidance removes). ``time_ratio``: the same for
    autopilot time. ``worst_time_ratio``: the largest new ÷ baseline time over seeds flown by
    both. The verdict applies the printed targets; a failed new run misses them.
    """
    runs: dict[tuple[tuple[str, str, str], str], dict[int, RunResult]] = {}
    for r in results:
        runs.setdefault((r.combo.cell, r.combo.guidance), {})[r.seed] = r
    cells = list(dict.fromkeys(r.combo.cell for r in results))
    out: list[dict[str, Any]] = []
    for cell in cells:
        a, b = runs.get((cell, new)), runs.get((cell, baseline))
        if not a or not b:
            continue
        mean_new = mean_worst([r.xt_rms_m for r in a.values()])["mean"]
        mean_base = mean_worst([r.xt_rms_m for r in b.values()])["mean"]
        t_new = mean_worst([r.time_s for r in a.values()])["mean"]
        t_base = mean_worst([r.time_s for r in b.values()])["mean"]
        seed_ratios = [navmetrics.ratio(a[s].time_s, b[s].time_s) for s in sorted(set(a) & set(b))]
        worst_t = max((x for x in seed_ratios if x is not None), default=None)
        rms_ratio = navmetrics.ratio(mean_new, mean_base)
        est_ratio = navmetrics.ratio(
            mean_worst([r.est_xt_rms_m for r in a.values()])["mean"],
            mean_worst([r.est_xt_rms_m for r in b.values()])["mean"],
        )
        failed = [s for s, r in sorted(a.items()) if not r.completed]
        if failed:
            verdict = f"misses ({new} failed, seed {', '.join(map(str, failed))})"
        elif rms_ratio is None or worst_t is None:
            verdict = "no figure"
        elif rms_ratio <= TARGET_RMS_RATIO and worst_t <= TARGET_TIME_RATIO:
            verdict = "meets"
        else:
            why = []
            if rms_ratio > TARGET_RMS_RATIO:
                why.append("RMS")
            if worst_t > TARGET_TIME_RATIO:
                why.append("time")
            verdict = f"misses ({', '.join(why)})"
        out.append(
            {
                "mission": cell[0],
                "mode": cell[1],
                "terrain": cell[2],
                "new": new,
                "baseline": baseline,
                "rms_ratio": rms_ratio,
                "est_rms_ratio": est_ratio,
                "time_ratio": navmetrics.ratio(t_new, t_base),
                "worst_time_ratio": worst_t,
                "verdict": verdict,
            }
        )
    return out


RUN_HEADERS = (
    "mission", "mode", "terrain", "guidance", "seed", "completed", "wps", "xt_rms_m",
    "xt_max_m", "final_m", "est_rms_m", "t_ap_s", "effort", "t_wall_s", "exit",
)  # fmt: skip
AGG_HEADERS = (
    "mission", "mode", "terrain", "guidance", "completed", "xt_rms_m", "xt_max_m", "final_m",
    "est_rms_m", "t_ap_s", "effort",
)  # fmt: skip
RATIO_HEADERS = (
    "mission", "mode", "terrain", "rms_ratio", "est_rms_ratio", "time_ratio", "worst_t_ratio",
    "target",
)  # fmt: skip


def run_row(r: RunResult) -> tuple[str, ...]:
    return (
        r.combo.mission,
        r.combo.mode,
        r.combo.terrain,
        r.combo.guidance,
        str(r.seed),
        "yes" if r.completed else ("REFUSED" if r.refused else "FAILED"),
        f"{r.reached}/{r.total}",
        _num(r.xt_rms_m),
        _num(r.xt_max_m),
        _num(r.final_error_m),
        _num(r.est_xt_rms_m),
        _num(r.time_s, ".1f"),
        _num(r.effort, ".1f"),
        _num(r.wall_s, ".1f"),
        "timeout" if r.exit_code is None else str(r.exit_code),
    )


def _mw(figure: dict[str, float | None], spec: str = ".2f") -> str:
    return f"{_num(figure['mean'], spec)}/{_num(figure['worst'], spec)}"


def aggregate_rows(cells: Sequence[dict[str, Any]]) -> list[tuple[str, ...]]:
    return [
        (
            c["mission"], c["mode"], c["terrain"], c["guidance"], c["completed"],
            _mw(c["xt_rms_m"]), _mw(c["xt_max_m"]), _mw(c["final_error_m"]),
            _mw(c["est_xt_rms_m"]), _mw(c["time_s"], ".1f"), _mw(c["effort"], ".1f"),
        )
        for c in cells
    ]  # fmt: skip


def ratio_rows(ratios: Sequence[dict[str, Any]]) -> list[tuple[str, ...]]:
    return [
        (
            r["mission"], r["mode"], r["terrain"], _num(r["rms_ratio"]),
            _num(r["est_rms_ratio"]), _num(r["time_ratio"]), _num(r["worst_time_ratio"]),
            r["verdict"],
        )
        for r in ratios
    ]  # fmt: skip


def format_table(headers: tuple[str, ...], rows: Sequence[tuple[str, ...]]) -> str:
    """Plain-text table: the first four columns left-aligned, the rest right-aligned."""
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(headers)]

    def line(cells: tuple[str, ...]) -> str:
        return "  ".join(
            c.ljust(w) if i < 4 else c.rjust(w)
            for i, (c, w) in enumerate(zip(cells, widths, strict=True))
        ).rstrip()

    return "\n".join([line(headers), *(line(r) for r in rows)])


def failure_lines(results: Sequence[RunResult]) -> list[str]:
    return [
        f"FAILED {r.combo.label}, seed {r.seed}, exit "
        f"{'timeout' if r.exit_code is None else r.exit_code}: {r.fault or 'no fault recorded'}"
        for r in results
        if not r.completed
    ]


def results_section(
    results: Sequence[RunResult], meta: dict[str, Any], notes: Sequence[str]
) -> dict[str, Any]:
    """The ``navigation`` section of bench/results/latest.json."""
    runs = []
    for r in results:
        row = asdict(r)
        row.update(row.pop("combo"))
        runs.append(row)
    return {
        "meta": meta,
        "notes": list(notes),
        "target": TARGET_TEXT,
        "cells": aggregate(results),
        "ratios": compare(results),
        "runs": runs,
        "failures": failure_lines(results),
    }


# -- I/O shell --------------------------------------------------------------------------------


def _log_tail(path: Path) -> str:
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError as exc:
        return f"(cannot read {path}: {exc})"
    wanted = [ln for ln in lines if "level=error" in ln or "level=warning" in ln] or lines
    return " | ".join(wanted[-LOG_TAIL_LINES:])


class TruePoseSampler:
    """Records the simulator's true pose (t_boot_s, north_m, east_m) on its own thread.

    It waits on the simulator's snapshot condition (:meth:`SimServer.wait_for`) and keeps one
    sample per ``period_s`` of simulated time.
    """

    def __init__(self, wait_for: Callable[..., Any], period_s: float = TRUE_POSE_PERIOD_S):
        self._wait_for = wait_for
        self._period_s = period_s
        self._stop = threading.Event()
        self.samples: list[tuple[float, float, float]] = []
        self._last_ms = -(10**9)
        self._thread = threading.Thread(target=self._run, name="true-pose", daemon=True)

    def _take(self, snap: Any) -> bool:
        ms = int(snap.time_boot_ms)
        if ms - self._last_ms >= self._period_s * 1000.0 and not snap.silent:
            self._last_ms = ms
            self.samples.append((ms / 1000.0, float(snap.north_m), float(snap.east_m)))
        return self._stop.is_set()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                self._wait_for(self._take, SAMPLER_WAIT_S)
            except TimeoutError:
                continue

    def __enter__(self) -> TruePoseSampler:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(timeout=5.0 * SAMPLER_WAIT_S)


def _mission_waypoints(mission_path: Path) -> list[tuple[float, float]]:
    from helixd.config import ControlConfig, MissionLimits
    from helixd.mission import load_mission
    from helixd.mission.plan import resolve_plan

    plan = resolve_plan(load_mission(mission_path), ControlConfig(), MissionLimits())
    return [(w.x_m, w.y_m) for w in plan.waypoints]


def run_one(
    combo: Combo,
    seed: int,
    speedup: float,
    noise: str,
    timeout_s: float,
    work: Path,
    default: str,
) -> RunResult:
    """Simulator in this process, the daemon as a subprocess; wait for it and read its run."""
    import logging

    import structlog

    from helixd.recorder.rows import read_flight_columns
    from helixd.sim import SimConfig, start_embedded

    structlog.configure(
        wrapper_class=structlog.make_filtering_bound_logger(logging.WARNING),
        logger_factory=structlog.PrintLoggerFactory(sys.stderr),
    )
    run_root = work / f"{combo.mission}-{combo.mode}-{combo.terrain}-{combo.guidance}-s{seed}"
    run_root.mkdir(parents=True, exist_ok=True)
    mission_path = run_root / "mission.yaml"
    source = (MISSIONS_DIR / f"{combo.mission}.yaml").read_text(encoding="utf-8")
    mission_path.write_text(mission_with_mode(source, combo.mode), encoding="utf-8")
    sim_cfg = SimConfig(
        speedup=speedup,
        terrain=combo.terrain,
        noise=noise,
        seed=seed,
    )
    server, url = start_embedded(sim_cfg)
    try:
        cfg_path = run_root / "helixd.yaml"
        cfg = {**daemon_config(combo.guidance, default), "link": {"url": url}}
        cfg_path.write_text(yaml.safe_dump(cfg), encoding="utf-8")
        log_path = run_root / "daemon.log"
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH")) if p)
        env.pop("NOTIFY_SOCKET", None)
        cmd = [
            sys.executable, "-m", "helixd", "run", "--connect", url,
            "--mission", str(mission_path), "--config", str(cfg_path),
            "--run-dir", str(run_root / "runs"),
        ]  # fmt: skip
        t0 = time.monotonic()
        with (
            TruePoseSampler(server.wait_for) as sampler,
            log_path.open("w", encoding="utf-8") as log_fh,
        ):
            proc = subprocess.Popen(
                cmd, stdout=subprocess.DEVNULL, stderr=log_fh, env=env, cwd=run_root
            )
            exit_code: int | None
            try:
                exit_code = proc.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                exit_code = None
                proc.send_signal(signal.SIGINT)  # the daemon's own stop path
                try:
                    proc.wait(timeout=KILL_GRACE_S)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()
        wall_s = time.monotonic() - t0
    finally:
        server.stop()
    runs = sorted(p for p in (run_root / "runs").glob("*") if p.is_dir())
    summary: dict[str, Any] | None = None
    figures = TrueFigures()
    if runs:
        try:
            summary = json.loads((runs[-1] / "summary.json").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            summary = None
        try:
            cols = read_flight_columns(runs[-1] / "flight.csv")
            columns = {k: [float(v) for v in cols[k]] for k in FLIGHT_COLUMNS}
            figures = true_figures(columns, _mission_waypoints(mission_path), sampler.samples)
        except (OSError, ValueError, KeyError):
            figures = TrueFigures()
    return result_from_summary(
        combo, seed, summary, figures, wall_s, exit_code, _log_tail(log_path)
    )


def main(
    speedup: float = typer.Option(5.0, min=0.5, max=20.0, help="simulator speed-up"),
    noise: str = typer.Option("thesis", help="pose noise: none, low or thesis"),
    seed: int = typer.Option(1, min=0, help="first noise seed (run i uses seed + i)"),
    runs: int = typer.Option(3, min=1, max=50, help="runs per cell (seeds seed..seed+runs-1)"),
    only: list[str] = typer.Option(  # noqa: B008 - typer's idiom
        [],
        help="mission, mode, terrain, or several joined by / (square/roll, omni/mud); repeatable",
    ),
    terrain: list[str] = typer.Option(  # noqa: B008 - typer's idiom
        [], help="terrain to fly on, repeatable (default hard and mud)"
    ),
    guidance: list[str] = typer.Option(  # noqa: B008 - typer's idiom
        [], help="guidance law, repeatable: line, thesis (default both)"
    ),
    roll_anywhere: bool = typer.Option(False, help="fly ROLL on mud and sand too"),
    jobs: int = typer.Option(2, min=1, max=16, help="runs in parallel (worker processes)"),
    timeout_s: float = typer.Option(300.0, min=10.0, help="wall seconds per run before SIGINT"),
    keep: Path | None = typer.Option(  # noqa: B008 - typer's idiom
        None, help="keep run directories and daemon logs under this directory"
    ),
    results_dir: Path = typer.Option(  # noqa: B008 - typer's idiom
        ROOT / "bench" / "results", help="where latest.json / latest.md are written"
    ),
) -> None:
    """Fly the mission × mode × terrain × guidance matrix; print and write the results."""
    if noise not in NOISES:
        raise typer.BadParameter(f"expected one of {', '.join(NOISES)}", param_hint="--noise")
    try:
        terrains = parse_terrains(terrain)
        guidances = parse_guidances(guidance)
        combos = select_combos(only, terrains, guidances, roll_anywhere)
    except ValueError as exc:
        raise typer.BadParameter(str(exc)) from None
    default = default_guidance()
    notes: list[str] = []
    refused: list[str] = []
    for g in guidances:
        why = guidance_refusal(g, default)
        if why is not None:
            refused.append(g)
            notes.append(
                f"guidance {g!r} REFUSED by this daemon's config model, its runs skipped: {why}"
            )
    if refused:
        combos = [c for c in combos if c.guidance not in refused]
    for note in notes:
        typer.echo(note, err=True)
    if not roll_anywhere and any(t in NO_ROLL_TERRAINS for t in terrains):
        notes.append("ROLL flown on hard/grass only (mud: 30 % roll efficiency and digging)")
    todo = [(c, seed + i) for i in range(runs) for c in combos]
    if not todo:
        typer.echo("nothing to run (every selected guidance was refused); no results written")
        raise typer.Exit(2)
    typer.echo(
        f"navigation benchmark: {len(combos)} cell(s) x {runs} seed(s) = {len(todo)} runs, "
        f"noise {noise}, speed-up {speedup:g}, {jobs} worker(s), daemon default guidance "
        f"{default!r}"
    )
    results: list[RunResult] = []
    t0 = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="helixd-bench-nav-") as tmp:
        work = keep if keep is not None else Path(tmp)
        ctx = multiprocessing.get_context("spawn")
        with concurrent.futures.ProcessPoolExecutor(max_workers=jobs, mp_context=ctx) as pool:
            futures = {
                pool.submit(run_one, c, s, speedup, noise, timeout_s, work, default): (c, s)
                for c, s in todo
            }
            for n, fut in enumerate(concurrent.futures.as_completed(futures), 1):
                r = fut.result()
                results.append(r)
                status = "ok" if r.completed else f"FAILED ({r.fault})"
                typer.echo(
                    f"  [{n}/{len(todo)}] {r.combo.label:<28} seed {r.seed}: {status}, "
                    f"true RMS {_num(r.xt_rms_m)} m, {r.wall_s:.0f} s wall, "
                    f"{time.monotonic() - t0:.0f} s elapsed",
                    err=True,
                )
    total_s = time.monotonic() - t0
    order = {key: i for i, key in enumerate(todo)}
    results.sort(key=lambda r: order.get((r.combo, r.seed), 0))
    if any(r.refused for r in results):
        notes.append("the daemon refused its config (unknown key) in some runs: see failures")
    meta = {
        "runs": len(results),
        "completed": sum(r.completed for r in results),
        "noise": noise,
        "speedup": speedup,
        "jobs": jobs,
        "seeds": f"{seed}..{seed + runs - 1}",
        "daemon_default_guidance": default,
        "wall_s": round(total_s, 1),
        "finished_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }
    section = results_section(results, meta, notes)
    typer.echo("")
    typer.echo(format_table(RUN_HEADERS, [run_row(r) for r in results]))
    typer.echo("")
    typer.echo("per cell over seeds (mean/worst), true pose:")
    typer.echo(format_table(AGG_HEADERS, aggregate_rows(section["cells"])))
    if section["ratios"]:
        typer.echo("")
        typer.echo(f"{NEW} / {BASELINE} in this run; target (not asserted): {TARGET_TEXT}")
        typer.echo(format_table(RATIO_HEADERS, ratio_rows(section["ratios"])))
    typer.echo("")
    for line in section["failures"]:
        typer.echo(line)
    for note in notes:
        typer.echo(f"NOTE: {note}")
    path = write_section("navigation", section, results_dir)
    typer.echo(
        f"{meta['completed']}/{len(results)} runs completed in {total_s:.0f} s wall. "
        "xt/final on the simulator's TRUE pose vs the planned legs; est_rms_m on the pose the "
        "daemon saw; t_ap_s autopilot time; effort = ∫ Σ|scroll fraction| dt. "
        f"Written to {path} and latest.md."
    )
    if keep is not None:
        typer.echo(f"run directories kept under {keep}")
    if section["failures"] or refused:
        raise typer.Exit(1)


if __name__ == "__main__":
    typer.run(main)
