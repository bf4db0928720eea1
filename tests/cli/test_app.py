"""The command line itself: --version and -h, flags, help texts whole and free of internals."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import typer.main

from helixd import __version__
from helixd.cli.app import app
from tests.support.cli import run_main

COMMANDS = [
    [],
    ["check"],
    ["run"],
    ["status"],
    ["sim"],
    ["plot"],
    ["replay"],
    ["export"],
    ["version"],
    ["mission"],
    ["mission", "convert"],
    ["mission", "survey"],
    ["mission", "download"],
    ["mission", "upload"],
]


@pytest.mark.parametrize("flag", ["--version", "-V"])
def test_version_flag(flag: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run_main([flag], capsys)
    assert (code, out, err) == (0, f"helixd {__version__}\n", "")


@pytest.mark.parametrize("command", COMMANDS, ids=lambda c: " ".join(c) or "helixd")
def test_every_help_is_whole_and_speaks_to_the_operator(
    command: list[str], capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """-h works everywhere; at 80 columns nothing is cut ("mission.ground_station_…", a
    command's summary ending in "..."), no flag shows a "<bool>" argument, and no help names
    helixd's modules or carries reStructuredText markup."""
    monkeypatch.setenv("COLUMNS", "80")
    code, out, err = run_main([*command, "-h"], capsys)
    assert code == 0 and err == "", err
    assert out.startswith("Usage: ")
    assert "…" not in out and "<bool>" not in out
    body = [ln for ln in out.splitlines() if not ln.startswith("Usage:")]
    assert not [ln for ln in body if ln.rstrip().endswith("...")]
    assert not re.search(r"\bhelixd\.(?!yaml)[a-z]", out), out
    assert "``" not in out and ":mod:" not in out and ":func:" not in out


def test_run_help_names_every_option_whole(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("COLUMNS", "80")
    _, out, _ = run_main(["run", "-h"], capsys)
    text = " ".join(out.split())
    assert "(default: mission.ground_station_mode)" in text
    assert re.search(r"^\s+--sim\s+fly against", out, re.MULTILINE)  # a plain flag


def test_a_flag_takes_no_value(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run_main(["run", "--mission", "square", "--sim", "true"], capsys)
    assert code == 2
    assert err.count("error:") == 1 and "unexpected extra argument(s) (true)" in err


@pytest.mark.parametrize("argv", [["sim", "--speedup", "50"], ["run", "--sim-speedup", "50"]])
def test_sim_and_run_share_the_speedup_bound(
    argv: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    code, _, err = run_main([*argv, "--mission", "square"] if argv[0] == "run" else argv, capsys)
    assert code == 2
    assert err.count("error:") == 1 and "less than or equal to 20" in err


@pytest.mark.parametrize("command", [["sim"], ["run"]])
def test_sim_and_run_show_the_same_speedup_range(
    command: list[str], capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("COLUMNS", "200")
    _, out, _ = run_main([*command, "-h"], capsys)
    assert "0.1<=x<=20.0" in out


def test_bare_check_asks_for_a_mission_and_lists_the_available_ones(
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    tmp_path: Path,
) -> None:
    """It said 'mission.yaml: mission file not found', naming a file nobody asked for."""
    monkeypatch.chdir(tmp_path)
    missions = tmp_path / "config" / "missions"
    missions.mkdir(parents=True)
    (missions / "square.yaml").write_text("name: square\n", encoding="utf-8")
    (missions / "notes.txt").write_text("not a mission\n", encoding="utf-8")
    code, _, err = run_main(["check"], capsys)
    assert code == 2
    assert "check needs --mission FILE; available: config/missions/square.yaml" in err
    assert "mission.yaml" not in err and "notes.txt" not in err


def _command_paths() -> list[list[str]]:
    paths: list[list[str]] = []

    def walk(cmd: Any, path: list[str]) -> None:
        paths.append(path)
        for name, sub in getattr(cmd, "commands", {}).items():
            walk(sub, [*path, name])

    walk(typer.main.get_command(app), [])
    return paths


def test_no_option_help_shows_a_python_type_for_a_metavar(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Before: `autopilot setup -h` showed `--file <list[Path]>`, `sim -h` `--listen
    <list[str]>`: a repeatable option's metavar is what one of them is. (A list argument's
    type, `survey-map RUNS... <list[Path]>`, typer prints whatever its metavar.)"""
    paths = _command_paths()
    assert ["autopilot", "setup"] in paths and ["sim"] in paths
    for path in paths:
        code, out, err = run_main([*path, "-h"], capsys)
        assert code == 0, (path, err)
        options = [ln for ln in out.splitlines() if ln.lstrip().startswith("-")]
        assert not [ln for ln in options if re.search(r"<(list|tuple|dict)\[", ln)], (path, out)


@pytest.mark.parametrize(
    ("argv", "line"),
    [
        (["check", "--mission", "square", "--mode", "rol"],
         "error: --mode 'rol' is not one of: roll, scroll, omni"),
        (["run", "--mission", "square", "--sim", "--sim-terrain", "rock"],
         "error: --sim-terrain 'rock' is not one of: hard, grass, sand, mud, water"),
    ],
)  # fmt: skip
def test_a_value_not_among_the_choices_names_them_plainly(
    argv: list[str], line: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: `--mode rol` answered `Invalid value for '--mode': Value error, 'rol' is not
    one of 'roll', 'scroll', 'omni'.`"""
    code, _, err = run_main(argv, capsys)
    assert code == 2
    assert err.strip().splitlines() == [line]


def test_the_cli_starts_without_the_heavy_libraries_only_some_commands_need() -> None:
    """Before: every command, `helixd --version` included, imported tcod (the planner's A*)
    and matplotlib (plots, polygon rasters) at start: 0.3-0.7 s of the 3.1 s it took on a
    loaded 2-core machine. Judged by what is loaded, not by a time."""
    code = (
        "import sys, helixd.cli.app; "
        "print(sorted({m.split('.')[0] for m in sys.modules} & {'tcod', 'matplotlib'}))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    ).stdout
    assert out.strip() == "[]", out
