"""The one subprocess harness (tests/support/daemon.py) itself, on the real daemon waiting for
an autopilot that never answers: its log is pumped, waits are woken by it, stop() ends it by
SIGINT (exit 5, run recorded), kill() by SIGKILL."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from helixd.base.exitcodes import ExitCode
from tests.support.daemon import deep_merge, spawn_daemon
from tests.support.paths import REPO_ROOT

pytestmark = pytest.mark.integration

ROOT = REPO_ROOT
SQUARE = str(ROOT / "config" / "missions" / "square.yaml")


def waiting_args(run_root: Path) -> list[str]:
    """``helixd run`` listening where no autopilot will ever talk (it waits to connect)."""
    return [
        "run",
        "--mission",
        SQUARE,
        "--connect",
        "udpin:127.0.0.1:0",
        "--run-dir",
        str(run_root),
    ]


def test_stop_ends_a_running_child_by_sigint_with_its_whole_log(tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    proc = spawn_daemon(waiting_args(runs), cwd=tmp_path, run_root=runs, stdin=subprocess.DEVNULL)
    try:
        assert "udpin:127.0.0.1:0" in proc.wait_line("event=link_open", 30.0)
        assert proc.ended() is None
        proc.stop(15.0)
        assert proc.proc.returncode == ExitCode.OPERATOR_STOP
        # stopped before the link was made: one line naming the signal, no run directory
        assert "stopped by SIGINT while connecting" in proc.log_tail(5)
        assert not runs.exists() or not any(runs.iterdir())
        assert proc.ended() is not None
    finally:
        proc.kill()


def test_kill_and_a_failed_wait(tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    proc = spawn_daemon(waiting_args(runs), cwd=tmp_path, run_root=runs)
    try:
        proc.wait_line("event=link_open", 30.0)
        with pytest.raises(AssertionError, match="still running"):
            proc.wait_exit(0.1)
        proc.kill()
        assert proc.proc.returncode is not None and proc.proc.returncode < 0
        with pytest.raises(AssertionError, match="no log line"):
            proc.wait_line("never logged", 5.0)  # ended: fails at once, not after 5 s
    finally:
        proc.kill()


def test_exit_code_and_error_of_a_refused_start(tmp_path: Path) -> None:
    missing = str(tmp_path / "missing.yaml")
    proc = spawn_daemon(["run", "--mission", missing], cwd=tmp_path, run_root=tmp_path)
    assert proc.wait_exit(30.0) == ExitCode.USAGE
    assert "missing.yaml" in proc.log_text()


def test_deep_merge_merges_nested_keys_only() -> None:
    base = {"a": {"x": 1, "y": 2}, "b": 1}
    assert deep_merge(base, {"a": {"y": 3}, "c": 4}) == {"a": {"x": 1, "y": 3}, "b": 1, "c": 4}
    assert base == {"a": {"x": 1, "y": 2}, "b": 1}
