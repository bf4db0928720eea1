"""Running ``helixd``'s command line in-process, as its tests do."""

from __future__ import annotations

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
