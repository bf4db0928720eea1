"""The one subprocess harness for the daemon: the real ``python -m helixd …`` CLI as a child
process, its stderr log pumped into memory line by line.

Used by the integration suite (against the in-process simulator,
:mod:`tests.support.harness`) and by the opt-in SITL suite (``tests/sitl/conftest.py``).
Waiting is on a condition the log pump notifies, never on sleeps.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

LOG_TAIL_LINES = 40


def deep_merge(base: dict[str, Any], extra: dict[str, Any]) -> dict[str, Any]:
    """``extra`` merged over ``base``, nested dicts merged key by key (config overrides)."""
    out = dict(base)
    for key, value in extra.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = deep_merge(out[key], value)
        else:
            out[key] = value
    return out


@dataclass
class DaemonProc:
    """A running daemon process and every line it has logged to stderr so far."""

    proc: subprocess.Popen[str]
    run_root: Path
    lines: list[str] = field(default_factory=list)
    _cond: threading.Condition = field(default_factory=threading.Condition)
    _pump_thread: threading.Thread | None = None

    def start_pump(self) -> None:
        self._pump_thread = threading.Thread(target=self._pump, name="daemon-log", daemon=True)
        self._pump_thread.start()

    def _pump(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            with self._cond:
                self.lines.append(line.rstrip("\n"))
                self._cond.notify_all()
        with self._cond:
            self._cond.notify_all()

    def join_pump(self, timeout_s: float = 5.0) -> None:
        if self._pump_thread is not None:
            self._pump_thread.join(timeout=timeout_s)

    def mark(self) -> int:
        """How many lines were logged so far (for ``wait_line(after=...)``)."""
        with self._cond:
            return len(self.lines)

    def wait_line(self, needle: str, timeout_s: float, after: int = 0) -> str:
        """Block until a log line containing ``needle`` appears (or fail with the log); only
        lines from number ``after`` on count (see :meth:`mark`)."""
        deadline = time.monotonic() + timeout_s
        seen = after
        with self._cond:
            while True:
                for line in self.lines[seen:]:
                    if needle in line:
                        return line
                seen = len(self.lines)
                remaining = deadline - time.monotonic()
                if remaining <= 0 or (self.proc.poll() is not None and seen == len(self.lines)):
                    tail = "\n".join(self.lines[-LOG_TAIL_LINES:])
                    raise AssertionError(f"no log line with {needle!r}; daemon log tail:\n{tail}")
                self._cond.wait(timeout=min(remaining, 0.2))

    def wait_exit(self, timeout_s: float) -> int:
        """The exit code, once the process ended (and its log is read to the end)."""
        try:
            code = self.proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            raise AssertionError(
                f"daemon still running after {timeout_s:g} s:\n{self.log_tail()}"
            ) from None
        self.join_pump()
        return code

    def outcome(self, timeout_s: float) -> tuple[int, str, str]:
        """Once it exited within ``timeout_s``: (exit code, its plain ``helixd: RESULT`` line,
        its log)."""
        code = self.wait_exit(timeout_s)
        return code, self.wait_line("helixd: RESULT", 5.0), self.log_text()

    def ended(self) -> str | None:
        """None while running; else why it is no use waiting for it any more."""
        code = self.proc.poll()
        return None if code is None else f"helixd exited with {code}:\n{self.log_tail()}"

    def log_text(self) -> str:
        with self._cond:
            return "\n".join(self.lines)

    def log_tail(self, lines: int = LOG_TAIL_LINES) -> str:
        with self._cond:
            return "\n".join(self.lines[-lines:])

    def run_dir(self) -> Path:
        dirs = sorted(p for p in self.run_root.iterdir() if p.is_dir())
        assert dirs, f"no run directory under {self.run_root}"
        return dirs[-1]

    def signal(self, sig: signal.Signals) -> None:
        self.proc.send_signal(sig)

    def terminate_ok(self, timeout_s: float = 30.0) -> None:
        """SIGTERM, as systemd stops a service: the daemon exits 0 within ``timeout_s``."""
        self.proc.send_signal(signal.SIGTERM)
        assert self.wait_exit(timeout_s) == 0

    def kill(self, timeout_s: float = 10.0) -> None:
        """SIGKILL if still running (test clean-up), then wait for it and its log."""
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(timeout=timeout_s)
        self.join_pump()

    def stop(self, timeout_s: float) -> None:
        """SIGINT (the daemon stops, releases and asks for HOLD), SIGKILL if it overstays."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=timeout_s)
        self.join_pump()


def spawn_daemon(
    args: list[str],
    *,
    cwd: Path,
    run_root: Path,
    keep_notify_socket: bool = False,
    stdin: int | None = None,
) -> DaemonProc:
    """Start ``python -m helixd <args>`` in ``cwd`` (unbuffered, stdout discarded, stderr
    pumped). ``NOTIFY_SOCKET`` is removed from its environment unless ``keep_notify_socket``
    (the systemd test hands the daemon its own)."""
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    if not keep_notify_socket:
        env.pop("NOTIFY_SOCKET", None)
    proc = subprocess.Popen(
        [sys.executable, "-m", "helixd", *args],
        stdin=stdin,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        cwd=cwd,
    )
    handle = DaemonProc(proc=proc, run_root=run_root)
    handle.start_pump()
    return handle
