"""``helixd check`` warns, as ``run``'s preflight does, when the run directory's disk has less
free space than one flight's record; the check still passes (exit 0)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from helixd.cli.app import app
from helixd.recorder.retention import record_bytes_estimate
from tests.support.paths import REPO_ROOT

SQUARE = REPO_ROOT / "config" / "missions" / "square.yaml"


def _free(free_bytes: int) -> object:
    def disk_usage(path: Path) -> tuple[int, int, int]:
        assert path.exists()  # "runs" is not made yet: the folder it would be made in
        return (10**12, 10**12 - free_bytes, free_bytes)

    return disk_usage


def test_check_warns_when_a_flights_record_would_not_fit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(shutil, "disk_usage", _free(1_000_000))
    result = CliRunner().invoke(app, ["check", "--mission", str(SQUARE)])
    assert result.exit_code == 0, result.output
    warnings = [line for line in result.stderr.splitlines() if line.startswith("warning: ")]
    assert len(warnings) == 1, result.stderr
    assert "low disk space for the flight record: 1 MB free at runs" in warnings[0]
    assert "(recorder.run_root)" in warnings[0]


def test_check_is_quiet_with_room_for_the_record(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(shutil, "disk_usage", _free(record_bytes_estimate(3600.0)))
    result = CliRunner().invoke(app, ["check", "--mission", str(SQUARE)])
    assert result.exit_code == 0, result.output
    assert "low disk space" not in result.output + result.stderr
