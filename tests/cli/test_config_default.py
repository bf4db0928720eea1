"""Before: without -c, `run`, `check` and `serve` used the built-in defaults while the rover's
config sat in /etc/helixd/helixd.yaml, and `run` never said which config it read. Now the
default is $HELIXD_CONFIG, else /etc/helixd/helixd.yaml where it exists, else the built-in
defaults, and every command says which it read."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.config import load as config_module
from helixd.config.load import CONFIG_ENV, default_config_path
from tests.support.cli import run_main
from tests.support.paths import REPO_ROOT

SQUARE = REPO_ROOT / "config" / "missions" / "square.yaml"


def test_the_default_is_the_env_var_else_the_rovers_file_else_built_in(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    rover = tmp_path / "etc" / "helixd.yaml"
    monkeypatch.setattr(config_module, "ROVER_CONFIG_PATH", rover)
    assert default_config_path({}) is None  # no file on this machine: built-in defaults
    rover.parent.mkdir()
    rover.write_text("{}\n", encoding="utf-8")
    assert default_config_path({}) == rover  # the rover's file, unless told otherwise
    assert default_config_path({CONFIG_ENV: "/srv/other.yaml"}) == Path("/srv/other.yaml")
    assert default_config_path({CONFIG_ENV: ""}) is None  # empty: the built-in defaults


def write_config(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "helixd.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def test_check_reads_the_default_config_and_says_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write_config(tmp_path, "control:\n  waypoint_tolerance_m: 0.77\n")
    monkeypatch.setenv(CONFIG_ENV, str(path))
    code, out, err = run_main(["check", "--mission", str(SQUARE)], capsys)
    assert code == 0, err
    assert f"config  : {path}  OK" in out.splitlines()
    assert "0.77" in out  # the file's waypoint tolerance, not the built-in one
    monkeypatch.setenv(CONFIG_ENV, "")
    code, out, _ = run_main(["check", "--mission", str(SQUARE)], capsys)
    assert code == 0 and "config  : (built-in defaults)  OK" in out.splitlines()


def test_run_and_serve_say_which_config_they_read_and_refuse_a_bad_one(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write_config(tmp_path, "control:\n  waypoint_tolerance_m: -1\n")
    monkeypatch.setenv(CONFIG_ENV, str(path))
    for command in (["run", "--mission", str(SQUARE)], ["serve", "--mode", "roll"]):
        code, out, err = run_main(command, capsys)
        assert code == ExitCode.USAGE, (command, err)
        assert f"{path}: control.waypoint_tolerance_m" in err, (command, err)
    good = write_config(tmp_path, "{}\n")
    monkeypatch.setenv(CONFIG_ENV, str(good))
    code, out, err = run_main(
        ["run", "--mission", str(SQUARE), "--connect", "tcp:", "--run-dir", str(tmp_path)], capsys
    )
    assert code == ExitCode.USAGE  # refused at --connect, after saying the config
    assert out.splitlines()[0] == f"config  : {good}"
