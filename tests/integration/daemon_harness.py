"""Run the real ``helixd run`` CLI as a subprocess against the in-process simulator over UDP.

The simulator runs in this test process (a thread, see simharness); the daemon is a separate
process talking MAVLink to it exactly as it would to a Pixhawk. Assertions are made from the
simulator's side: what the autopilot saw, not what the daemon claims.
"""

from __future__ import annotations

import itertools
import math
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from helixd.sim import SimServer
from helixd.sim.snapshot import SimSnapshot
from tests.integration.simharness import running_sim

ROOT = Path(__file__).resolve().parents[2]
MISSIONS = ROOT / "config" / "missions"
SPEEDUP = 5.0  # simulator speed-up for daemon runs (sim time runs 5× wall)
NEUTRAL_US = 1500
NEUTRAL_TOLERANCE_US = 10
KEEP_NOTIFY_SOCKET = False  # the systemd test hands its own NOTIFY_SOCKET to the daemon

# Daemon settings for tests: faster setup, everything else at its field default.
BASE_CONFIG: dict[str, Any] = {
    "safety": {"connect_timeout_s": 20.0, "arm_retry_interval_s": 0.5},
}


def deep_merge(base: dict[str, Any], extra: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for key, value in extra.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = deep_merge(out[key], value)
        else:
            out[key] = value
    return out


@dataclass
class DaemonProc:
    proc: subprocess.Popen[str]
    run_root: Path
    lines: list[str] = field(default_factory=list)
    _cond: threading.Condition = field(default_factory=threading.Condition)

    def _pump(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            with self._cond:
                self.lines.append(line.rstrip("\n"))
                self._cond.notify_all()
        with self._cond:
            self._cond.notify_all()

    def wait_line(self, needle: str, timeout_s: float) -> str:
        """Block until a log line containing ``needle`` appears (or fail with the log)."""
        deadline = time.monotonic() + timeout_s
        seen = 0
        with self._cond:
            while True:
                for line in self.lines[seen:]:
                    if needle in line:
                        return line
                seen = len(self.lines)
                remaining = deadline - time.monotonic()
                if remaining <= 0 or (self.proc.poll() is not None and seen == len(self.lines)):
                    tail = "\n".join(self.lines[-40:])
                    raise AssertionError(f"no log line with {needle!r}; daemon log tail:\n{tail}")
                self._cond.wait(timeout=min(remaining, 0.2))

    def wait_exit(self, timeout_s: float) -> int:
        try:
            return self.proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            tail = "\n".join(self.lines[-40:])
            raise AssertionError(f"daemon still running after {timeout_s} s:\n{tail}") from None

    def log_text(self) -> str:
        with self._cond:
            return "\n".join(self.lines)

    def run_dir(self) -> Path:
        dirs = sorted(p for p in self.run_root.iterdir() if p.is_dir())
        assert dirs, f"no run directory under {self.run_root}"
        return dirs[-1]

    def signal(self, sig: signal.Signals) -> None:
        self.proc.send_signal(sig)


@contextmanager
def daemon(
    tmp_path: Path,
    url: str,
    mission: str | Path = "square",
    config: dict[str, Any] | None = None,
) -> Iterator[DaemonProc]:
    cfg = deep_merge(BASE_CONFIG, config or {})
    cfg = deep_merge(cfg, {"link": {"url": url}})
    cfg_path = tmp_path / "helixd.yaml"
    cfg_path.write_text(yaml.safe_dump(cfg), encoding="utf-8")
    mission_path = mission if isinstance(mission, Path) else MISSIONS / f"{mission}.yaml"
    run_root = tmp_path / "runs"
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    if not KEEP_NOTIFY_SOCKET:
        env.pop("NOTIFY_SOCKET", None)
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "helixd",
            "run",
            "--mission",
            str(mission_path),
            "--config",
            str(cfg_path),
            "--run-dir",
            str(run_root),
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        cwd=tmp_path,
    )
    handle = DaemonProc(proc=proc, run_root=run_root)
    pump = threading.Thread(target=handle._pump, name="daemon-log", daemon=True)
    pump.start()
    try:
        yield handle
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10)
        pump.join(timeout=5)


@contextmanager
def sim_and_daemon(
    tmp_path: Path,
    mission: str | Path = "square",
    config: dict[str, Any] | None = None,
    **sim_overrides: Any,
) -> Iterator[tuple[SimServer, DaemonProc]]:
    overrides = {"speedup": SPEEDUP, **sim_overrides}
    with running_sim(**overrides) as (server, url), daemon(tmp_path, url, mission, config) as d:
        yield server, d


def scrolls_neutral(s: SimSnapshot) -> bool:
    return all(abs(p - NEUTRAL_US) <= NEUTRAL_TOLERANCE_US for p in s.scroll_pwm_us)


def overrides_released(s: SimSnapshot) -> bool:
    return not any(s.overrides_active)


def secured(s: SimSnapshot) -> bool:
    """What the autopilot must show after any fall-back: HOLD, no override, scrolls neutral."""
    return s.mode == "HOLD" and overrides_released(s) and scrolls_neutral(s)


def wait_moving(server: SimServer, timeout_s: float = 40.0) -> SimSnapshot:
    """Until the rover is armed and driving its mission (scrolls commanded, rover moving)."""
    return server.wait_for(lambda s: s.armed and s.speed_mps > 0.1, timeout_s)


def time_until(
    server: SimServer, predicate: Callable[[SimSnapshot], bool], since_s: float, timeout_s: float
) -> float:
    """Wall seconds from ``since_s`` (monotonic) until ``predicate`` holds in the simulator
    (woken by each snapshot the simulator publishes)."""
    try:
        server.wait_for(predicate, timeout_s)
    except TimeoutError as exc:
        raise AssertionError(f"not reached within {timeout_s} s: {exc}") from None
    return time.monotonic() - since_s


@dataclass(frozen=True)
class Trace:
    """What the simulator showed, polled every few ms: (monotonic wall s, snapshot) pairs."""

    samples: list[tuple[float, SimSnapshot]]

    def first(self, predicate: Callable[[SimSnapshot], bool], after_s: float = -1e18) -> float:
        """Wall time of the first sample at or after ``after_s`` where ``predicate`` holds."""
        for t, snap in self.samples:
            if t >= after_s and predicate(snap):
                return t
        raise AssertionError(f"never seen in {len(self.samples)} samples")

    def driven_after(self, after_s: float) -> list[tuple[float, tuple[int, int, int, int]]]:
        """Samples after ``after_s`` whose scroll outputs were away from neutral."""
        return [
            (t, s.scroll_pwm_us) for t, s in self.samples if t > after_s and not scrolls_neutral(s)
        ]

    def yaw_change_deg(self, after_s: float) -> float:
        """Total |rotation| of the rover (truth) after ``after_s``, unwrapped, in degrees."""
        yaws = [s.yaw_ned_rad for t, s in self.samples if t >= after_s]
        total = 0.0
        for a, b in itertools.pairwise(yaws):
            total += abs(math.remainder(b - a, 2 * math.pi))
        return math.degrees(total)


def record_until(
    server: SimServer, predicate: Callable[[SimSnapshot], bool], timeout_s: float
) -> Trace:
    """Every snapshot the simulator publishes until ``predicate`` holds (and 0.2 s more)."""
    samples: list[tuple[float, SimSnapshot]] = []
    deadline = time.monotonic() + timeout_s
    done_at: float | None = None
    snap: SimSnapshot | None = None
    while True:
        try:
            snap = server.next_snapshot(snap, max(0.0, deadline - time.monotonic()))
        except TimeoutError as exc:
            raise AssertionError(f"not reached within {timeout_s} s: {exc}") from None
        now = time.monotonic()
        samples.append((now, snap))
        if done_at is None and predicate(snap):
            done_at = now
        if done_at is not None and now - done_at >= 0.2:
            return Trace(samples)
        if now > deadline:
            raise AssertionError(f"not reached within {timeout_s} s; simulator: {snap.describe()}")
