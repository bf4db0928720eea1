#!/usr/bin/env python3
"""Navigation benchmark: the shipped missions in every motion mode against the simulator.

DESIGN §6: "the 10 m square, 2 m hexagon and r = 2 m circle in ROLL, SCROLL and OMNI each
complete; the benchmark prints cross-track RMS/max, final error and time per run."

For each mission × mode (the mission file's ``mode`` replaced in a temporary copy) this starts
the built-in simulator in this process (:func:`helixd.sim.start_embedded`, thesis-like pose
noise by default, a terrain suited to the mode, a fixed seed) and runs the real daemon as a
subprocess — ``python -m helixd run --connect <url> --mission … --config … --run-dir …`` —
exactly as ``tests/integration/daemon_harness.py`` does. Results come from the run's
``summary.json``; the autopilot-time duration from the first and last ``t_boot_s`` of
``flight.csv``. A run that does not complete is printed as failed with its fault.

Usage::

    .venv/bin/python tools/bench_navigation.py                 # 9 runs, ~3 min
    .venv/bin/python tools/bench_navigation.py --only square/roll --only hexagon
    .venv/bin/python tools/bench_navigation.py --runs 3        # seeds 1..3, then mean/max
    .venv/bin/python tools/bench_navigation.py --terrain omni=grass --noise low

Cross-track, final error and waypoint arrivals are measured on the pose the daemon *sees*
(with thesis noise: ~0.7 m GPS-like drift), not on the simulator's true pose.
"""

from __future__ import annotations

import json
import math
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import typer
import yaml

from helixd.yamlio import parse_yaml_text

ROOT = Path(__file__).resolve().parents[1]
MISSIONS_DIR = ROOT / "config" / "missions"
MISSIONS = ("square", "hexagon", "circle")
MODES = ("roll", "scroll", "omni")
# Terrain per mode: ROLL needs hard ground; SCROLL and OMNI are the soft-media modes.
DEFAULT_TERRAIN = {"roll": "hard", "scroll": "mud", "omni": "mud"}
TERRAINS = ("hard", "grass", "sand", "mud")
NOISES = ("none", "low", "thesis")
# Simulated PreArm checks pass this long after boot (sim s); the daemon retries arming.
PREARM_DELAY_S = 5.0
# Daemon settings for the benchmark: quicker setup, everything else at its field default.
DAEMON_CONFIG: dict[str, Any] = {
    "safety": {"connect_timeout_s": 20.0, "arm_retry_interval_s": 0.5},
}
KILL_GRACE_S = 15.0
LOG_TAIL_LINES = 3


@dataclass(frozen=True)
class Combo:
    mission: str
    mode: str
    terrain: str

    @property
    def label(self) -> str:
        return f"{self.mission}/{self.mode}"


@dataclass
class RunResult:
    combo: Combo
    seed: int
    completed: bool
    reached: int
    total: int
    xt_rms_m: float | None
    xt_max_m: float | None
    final_error_m: float | None
    duration_ap_s: float | None  # autopilot (simulated) time, first to last control step
    wall_s: float  # the daemon process, start to exit
    exit_code: int | None  # None: killed after the timeout
    fault: str | None


# -- pure helpers -----------------------------------------------------------------------------


def parse_terrains(specs: list[str]) -> dict[str, str]:
    """``["omni=grass"]`` → the default table with omni on grass. ValueError on bad input."""
    table = dict(DEFAULT_TERRAIN)
    for spec in specs:
        mode, sep, terrain = spec.partition("=")
        if not sep or mode not in MODES or terrain not in TERRAINS:
            raise ValueError(
                f"--terrain {spec!r}: expected MODE=TERRAIN with MODE in {', '.join(MODES)} "
                f"and TERRAIN in {', '.join(TERRAINS)}"
            )
        table[mode] = terrain
    return table


def select_combos(only: list[str], terrains: dict[str, str]) -> list[Combo]:
    """Mission × mode combinations matching any ``only`` filter (all when empty).

    A filter is a mission (``square``), a mode (``roll``) or ``mission/mode``.
    """
    combos = [Combo(m, mode, terrains[mode]) for m in MISSIONS for mode in MODES]
    if not only:
        return combos
    picked: list[Combo] = []
    for spec in only:
        if spec in MISSIONS:
            match = [c for c in combos if c.mission == spec]
        elif spec in MODES:
            match = [c for c in combos if c.mode == spec]
        else:
            match = [c for c in combos if c.label == spec]
        if not match:
            raise ValueError(
                f"--only {spec!r}: expected a mission ({', '.join(MISSIONS)}), a mode "
                f"({', '.join(MODES)}) or MISSION/MODE"
            )
        picked += [c for c in match if c not in picked]
    return picked


def mission_with_mode(mission_yaml: str, mode: str) -> str:
    """The mission file's text with its motion mode replaced (comments are dropped)."""
    data = parse_yaml_text(mission_yaml)
    if not isinstance(data, dict):
        raise ValueError("a mission file is a YAML mapping")
    data["mode"] = mode
    return yaml.safe_dump(data, sort_keys=False)


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


def result_from_summary(
    combo: Combo,
    seed: int,
    summary: dict[str, Any] | None,
    duration_ap_s: float | None,
    wall_s: float,
    exit_code: int | None,
    log_tail: str,
) -> RunResult:
    """One benchmark row from ``summary.json`` (None when the daemon wrote none)."""
    if summary is None:
        return RunResult(
            combo, seed, False, 0, 0, None, None, None, duration_ap_s, wall_s, exit_code,
            f"no summary.json; daemon log: {log_tail or '(empty)'}",
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
        xt_rms_m=_opt_float(summary.get("cross_track_rms_m")),
        xt_max_m=_opt_float(summary.get("cross_track_max_m")),
        final_error_m=_opt_float(summary.get("final_error_m")),
        duration_ap_s=duration_ap_s,
        wall_s=wall_s,
        exit_code=exit_code,
        fault=None if fault is None else str(fault),
    )


def _opt_float(value: object) -> float | None:
    if isinstance(value, int | float) and math.isfinite(value):
        return float(value)
    return None


def _num(value: float | None, spec: str = ".2f") -> str:
    return "-" if value is None else format(value, spec)


def _mean_max(values: list[float | None], spec: str = ".2f") -> str:
    got = [v for v in values if v is not None]
    if not got:
        return "-"
    return f"{format(statistics.fmean(got), spec)}/{format(max(got), spec)}"


RUN_HEADERS = (
    "mission", "mode", "terrain", "seed", "completed", "wps", "xt_rms_m", "xt_max_m",
    "final_m", "t_ap_s", "t_wall_s", "exit",
)  # fmt: skip
AGG_HEADERS = (
    "mission", "mode", "terrain", "completed", "xt_rms_m", "xt_max_m", "final_m", "t_ap_s",
)  # fmt: skip


def run_row(r: RunResult) -> tuple[str, ...]:
    return (
        r.combo.mission,
        r.combo.mode,
        r.combo.terrain,
        str(r.seed),
        "yes" if r.completed else "FAILED",
        f"{r.reached}/{r.total}",
        _num(r.xt_rms_m),
        _num(r.xt_max_m),
        _num(r.final_error_m),
        _num(r.duration_ap_s, ".1f"),
        _num(r.wall_s, ".1f"),
        "timeout" if r.exit_code is None else str(r.exit_code),
    )


def aggregate_rows(results: list[RunResult]) -> list[tuple[str, ...]]:
    """Per mission/mode over seeds: completed k/n and mean/max of each figure."""
    by_combo: dict[Combo, list[RunResult]] = {}
    for r in results:
        by_combo.setdefault(r.combo, []).append(r)
    rows: list[tuple[str, ...]] = []
    for combo, rs in by_combo.items():
        rows.append(
            (
                combo.mission,
                combo.mode,
                combo.terrain,
                f"{sum(r.completed for r in rs)}/{len(rs)}",
                _mean_max([r.xt_rms_m for r in rs]),
                _mean_max([r.xt_max_m for r in rs]),
                _mean_max([r.final_error_m for r in rs]),
                _mean_max([r.duration_ap_s for r in rs], ".1f"),
            )
        )
    return rows


def format_table(headers: tuple[str, ...], rows: list[tuple[str, ...]]) -> str:
    """Plain-text table: first three columns left-aligned, the rest right-aligned."""
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(headers)]

    def line(cells: tuple[str, ...]) -> str:
        return "  ".join(
            c.ljust(w) if i < 3 else c.rjust(w)
            for i, (c, w) in enumerate(zip(cells, widths, strict=True))
        ).rstrip()

    return "\n".join([line(headers), *(line(r) for r in rows)])


def failure_lines(results: list[RunResult]) -> list[str]:
    return [
        f"FAILED {r.combo.label} on {r.combo.terrain}, seed {r.seed}, exit "
        f"{'timeout' if r.exit_code is None else r.exit_code}: {r.fault or 'no fault recorded'}"
        for r in results
        if not r.completed
    ]


# -- I/O shell --------------------------------------------------------------------------------


def _log_tail(path: Path) -> str:
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError as exc:
        return f"(cannot read {path}: {exc})"
    wanted = [ln for ln in lines if "level=error" in ln or "level=warning" in ln] or lines
    return " | ".join(wanted[-LOG_TAIL_LINES:])


def run_one(
    combo: Combo, seed: int, speedup: float, noise: str, timeout_s: float, work: Path
) -> RunResult:
    """Simulator in this process, the daemon as a subprocess; wait for it and read its run."""
    from helixd.sim import SimConfig, start_embedded

    run_root = work / f"{combo.mission}-{combo.mode}-{combo.terrain}-seed{seed}"
    run_root.mkdir(parents=True, exist_ok=True)
    mission_path = run_root / "mission.yaml"
    source = (MISSIONS_DIR / f"{combo.mission}.yaml").read_text(encoding="utf-8")
    mission_path.write_text(mission_with_mode(source, combo.mode), encoding="utf-8")
    sim_cfg = SimConfig(
        speedup=speedup,
        terrain=combo.terrain,
        noise=noise,
        seed=seed,
        prearm_delay_s=PREARM_DELAY_S,
    )
    server, url = start_embedded(sim_cfg)
    try:
        cfg_path = run_root / "helixd.yaml"
        cfg = {**DAEMON_CONFIG, "link": {"url": url}}
        cfg_path.write_text(yaml.safe_dump(cfg), encoding="utf-8")
        log_path = run_root / "daemon.log"
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        env.pop("NOTIFY_SOCKET", None)
        cmd = [
            sys.executable, "-m", "helixd", "run", "--connect", url,
            "--mission", str(mission_path), "--config", str(cfg_path),
            "--run-dir", str(run_root / "runs"),
        ]  # fmt: skip
        t0 = time.monotonic()
        with log_path.open("w", encoding="utf-8") as log_fh:
            proc = subprocess.Popen(
                cmd, stdout=subprocess.DEVNULL, stderr=log_fh, env=env, cwd=run_root
            )
            exit_code: int | None
            try:
                exit_code = proc.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                exit_code = None
                proc.send_signal(signal.SIGINT)  # the daemon's own stop path (HOLD, release)
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
    duration: float | None = None
    if runs:
        try:
            summary = json.loads((runs[-1] / "summary.json").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            summary = None
        try:
            duration = autopilot_duration_s((runs[-1] / "flight.csv").read_text(encoding="utf-8"))
        except OSError:
            duration = None
    return result_from_summary(
        combo, seed, summary, duration, wall_s, exit_code, _log_tail(log_path)
    )


def main(
    speedup: float = typer.Option(5.0, min=0.5, max=20.0, help="simulator speed-up"),
    noise: str = typer.Option("thesis", help="pose noise: none, low or thesis"),
    seed: int = typer.Option(1, min=0, help="first noise seed (run i uses seed + i)"),
    runs: int = typer.Option(1, min=1, max=50, help="runs per combination (different seeds)"),
    only: list[str] = typer.Option(  # noqa: B008 - typer's idiom
        [], help="mission, mode or mission/mode; repeatable (default: all 9)"
    ),
    terrain: list[str] = typer.Option(  # noqa: B008 - typer's idiom
        [], help="MODE=TERRAIN override, repeatable (default roll=hard scroll=mud omni=mud)"
    ),
    timeout_s: float = typer.Option(300.0, min=10.0, help="wall seconds per run before SIGINT"),
    keep: Path | None = typer.Option(  # noqa: B008 - typer's idiom
        None, help="keep run directories and daemon logs under this directory"
    ),
) -> None:
    """Fly every shipped mission in every mode against the simulator; print the results."""
    import logging

    import structlog

    structlog.configure(
        wrapper_class=structlog.make_filtering_bound_logger(logging.WARNING),
        logger_factory=structlog.PrintLoggerFactory(sys.stderr),
    )
    if noise not in NOISES:
        raise typer.BadParameter(f"expected one of {', '.join(NOISES)}", param_hint="--noise")
    try:
        combos = select_combos(only, parse_terrains(terrain))
    except ValueError as exc:
        raise typer.BadParameter(str(exc)) from None
    typer.echo(
        f"navigation benchmark: {len(combos)} combination(s) x {runs} run(s), noise {noise}, "
        f"speed-up {speedup:g}, seeds {seed}..{seed + runs - 1}"
    )
    results: list[RunResult] = []
    with tempfile.TemporaryDirectory(prefix="helixd-bench-nav-") as tmp:
        work = keep if keep is not None else Path(tmp)
        t0 = time.monotonic()
        for i in range(runs):
            for combo in combos:
                r = run_one(combo, seed + i, speedup, noise, timeout_s, work)
                results.append(r)
                status = "ok" if r.completed else f"FAILED ({r.fault})"
                typer.echo(
                    f"  {combo.label:<15} {combo.terrain:<5} seed {seed + i}: {status}, "
                    f"{r.wall_s:.0f} s wall",
                    err=True,
                )
        total_s = time.monotonic() - t0
    typer.echo("")
    typer.echo(format_table(RUN_HEADERS, [run_row(r) for r in results]))
    if runs > 1:
        typer.echo("")
        typer.echo(f"over {runs} seeds (mean/max):")
        typer.echo(format_table(AGG_HEADERS, aggregate_rows(results)))
    fails = failure_lines(results)
    typer.echo("")
    for line in fails:
        typer.echo(line)
    typer.echo(
        f"{len(results) - len(fails)}/{len(results)} runs completed in {total_s:.0f} s wall. "
        "Cross-track/final error on the pose the daemon sees; t_ap_s = autopilot (simulated) "
        "time from the first to the last control step."
    )
    if keep is not None:
        typer.echo(f"run directories kept under {keep}")
    if fails:
        raise typer.Exit(1)


if __name__ == "__main__":
    typer.run(main)
