"""Keeping the card from filling: retention of old run directories and the free-space check.

Retention (``recorder.keep_runs``, ``recorder.keep_bytes``) runs at the start of a run and
removes the OLDEST run directories under ``run_root`` (by the UTC stamp their name starts
with) until at most ``keep_runs`` remain and their total size is within ``keep_bytes``. Two are
never removed: the run being written, and the newest earlier run (the one a ``helixd run
--resume`` of an interrupted flight needs). Only directories named like a run
(``<UTC stamp>-<mission>``) are touched; anything else under ``run_root`` is left alone.

:func:`plan_prune` decides (pure); :func:`prune_runs` measures, removes and logs.

The free-space check compares ``shutil.disk_usage(run_root).free`` with one flight's record,
estimated from the flight's estimated duration (:func:`record_bytes_estimate`).
"""

from __future__ import annotations

import re
import shutil
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import structlog

log = structlog.get_logger(__name__)

RUN_NAME = re.compile(r"^\d{8}T\d{6}Z-")

# Bytes per second of flight, measured on `helixd run --sim --mode roll --mission
# tests/data/sim_square.plan` (default config, speed-up 1, 43.9 s of flight: each file's size
# divided by the summary's duration_mono_s): flight.csv 10.8 kB/s, link.tlog 7.4 kB/s,
# events.jsonl 0.4 kB/s. Rounded up: a real autopilot streams more telemetry than the simulator.
FLIGHT_CSV_BYTES_PER_S = 12_000
TLOG_BYTES_PER_S = 10_000
EVENTS_BYTES_PER_S = 1_000
RECORD_BYTES_PER_S = FLIGHT_CSV_BYTES_PER_S + TLOG_BYTES_PER_S + EVENTS_BYTES_PER_S
# Connecting, preflight and the stop: recorded too, and not in the flight's estimate.
RECORD_FIXED_BYTES = 2_000_000
# A flight with no estimate (the check could not make one) is reckoned this long (s).
UNKNOWN_FLIGHT_S = 3600.0


class RunDir(NamedTuple):
    path: Path
    size_bytes: int


def plan_prune(
    runs: Sequence[RunDir], keep_runs: int, keep_bytes: int | None, protected: set[Path]
) -> list[RunDir]:
    """The runs to remove, oldest first. ``runs`` in any order; ``protected`` never removed."""
    ordered = sorted(runs, key=lambda r: r.path.name)
    remaining = len(ordered)
    total = sum(r.size_bytes for r in ordered)
    out: list[RunDir] = []
    for run in ordered:
        over_count = remaining > keep_runs
        over_size = keep_bytes is not None and total > keep_bytes
        if not (over_count or over_size):
            break
        if run.path in protected:
            continue
        out.append(run)
        remaining -= 1
        total -= run.size_bytes
    return out


def _dir_size(path: Path) -> int:
    total = 0
    for p in path.rglob("*"):
        try:
            if p.is_file() and not p.is_symlink():
                total += p.stat().st_size
        except OSError:
            continue
    return total


def list_runs(run_root: Path) -> list[RunDir]:
    """Run directories directly under ``run_root`` (named ``<UTC stamp>-<mission>``)."""
    try:
        entries = list(run_root.iterdir())
    except OSError:
        return []
    return [
        RunDir(p, _dir_size(p))
        for p in entries
        if RUN_NAME.match(p.name) and p.is_dir() and not p.is_symlink()
    ]


def prune_runs(
    run_root: Path, keep_runs: int, keep_bytes: int | None, current: Path | None
) -> list[Path]:
    """Remove the oldest runs beyond the limits (see the module); log each. Never raises."""
    runs = list_runs(run_root)
    protected = set() if current is None else {current}
    earlier = sorted((r for r in runs if r.path != current), key=lambda r: r.path.name)
    if earlier:
        protected.add(earlier[-1].path)  # what --resume of an interrupted flight needs
    removed: list[Path] = []
    for run in plan_prune(runs, keep_runs, keep_bytes, protected):
        try:
            shutil.rmtree(run.path)
        except OSError as exc:
            log.warning("run_prune_failed", run_dir=str(run.path), error=exc.strerror or str(exc))
            continue
        removed.append(run.path)
        log.info("run_pruned", run_dir=str(run.path), size_bytes=run.size_bytes)
    if removed:
        log.info(
            "runs_pruned",
            count=len(removed),
            keep_runs=keep_runs,
            keep_bytes=keep_bytes,
            run_root=str(run_root),
        )
    return removed


DiskUsage = Callable[[Path], tuple[int, int, int]]  # shutil.disk_usage: (total, used, free)


def record_bytes_estimate(estimated_s: float | None) -> int:
    """One flight's record (flight.csv + link.tlog + events.jsonl) for a flight this long."""
    flight_s = UNKNOWN_FLIGHT_S if estimated_s is None or not estimated_s >= 0 else estimated_s
    return RECORD_FIXED_BYTES + int(flight_s * RECORD_BYTES_PER_S)


@dataclass(frozen=True)
class SpaceCheck:
    free_bytes: int
    needed_bytes: int

    @property
    def low(self) -> bool:
        return self.free_bytes < self.needed_bytes

    def text(self, path: Path) -> str:
        return (
            f"low disk space for the flight record: {self.free_bytes / 1e6:.0f} MB free at "
            f"{path}, one flight's record needs about {self.needed_bytes / 1e6:.0f} MB; "
            "free space or lower recorder.keep_runs / set recorder.keep_bytes"
        )


def low_space(
    path: Path,
    estimated_s: float | None,
    disk_usage: DiskUsage | None = None,
) -> SpaceCheck | None:
    """``path``'s free space when it is below one flight's record (``path`` not made yet: the
    nearest folder above it that exists, where it would be made); None when enough, or when
    the free space cannot be read."""
    usage = shutil.disk_usage if disk_usage is None else disk_usage
    where = path
    while not where.exists() and where.parent != where:
        where = where.parent
    try:
        free = int(usage(where)[2])
    except OSError:
        return None
    check = SpaceCheck(free, record_bytes_estimate(estimated_s))
    return check if check.low else None


def check_free_space(
    path: Path,
    estimated_s: float | None,
    disk_usage: DiskUsage | None = None,
) -> str | None:
    """A warning (also logged as ``disk_space_low``) when ``path``'s free space is below one
    flight's record; None when enough, or when the free space cannot be read."""
    check = low_space(path, estimated_s, disk_usage)
    if check is None:
        return None
    log.warning(
        "disk_space_low",
        path=str(path),
        free_bytes=check.free_bytes,
        needed_bytes=check.needed_bytes,
        estimated_s=estimated_s,
    )
    return check.text(path)


__all__ = [
    "RECORD_BYTES_PER_S",
    "DiskUsage",
    "RunDir",
    "SpaceCheck",
    "check_free_space",
    "list_runs",
    "low_space",
    "plan_prune",
    "prune_runs",
    "record_bytes_estimate",
]
