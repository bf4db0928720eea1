"""Running ``helixd``'s command line in-process, as its tests do, or as its own process."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path

import pytest

from helixd.cli.app import main


def main_exit(argv: list[str]) -> int:
    """``helixd ARGV`` in this process; its exit code."""
    with pytest.raises(SystemExit) as info:
        main(argv)
    code = info.value.code
    return code if isinstance(code, int) else 0


def run_main(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """``helixd ARGV`` in this process: (exit code, stdout, stderr)."""
    code = main_exit(argv)
    out, err = capsys.readouterr()
    return code, out, err


def check_out(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """``helixd check ARGV`` in this process, passed (exit 0, else AssertionError with its
    output); its stdout."""
    code, out, err = run_main(["check", *argv], capsys)
    assert code == 0, out + err
    return out


FAST_CONNECT = "startup:\n  connect_timeout_s: 5.0\n"  # a test's autopilot answers at once


def autopilot_verb(
    tmp_path: Path,
    verb: str,
    url: str,
    capsys: pytest.CaptureFixture[str],
    *more: str,
    config: str = FAST_CONNECT,
) -> tuple[int, str, str]:
    """``helixd autopilot VERB --connect URL --config FILE MORE...`` in this process, FILE
    ``config`` (:func:`config_file`): (exit code, stdout, stderr)."""
    argv = ["autopilot", verb, "--connect", url, "--config", config_file(tmp_path, config)]
    return run_main([*argv, *more], capsys)


def helixd_process(
    argv: list[str], cwd: Path, timeout_s: float = 60.0, env: Mapping[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    """``python -m helixd ARGV`` as its own process in ``cwd``, its output captured as text."""
    command = [sys.executable, "-m", "helixd", *argv]
    return subprocess.run(
        command, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout_s, check=False
    )


def config_file(tmp_path: Path, text: str) -> str:
    """``text`` as ``tmp_path``/helixd.yaml; its path, for ``--config``."""
    path = tmp_path / "helixd.yaml"
    path.write_text(text, encoding="utf-8")
    return str(path)
