"""Command-line errors: exit 2, one `error:` line each, nothing created; missions by name."""

from __future__ import annotations

import socket
from pathlib import Path

import pytest

from helixd.mission.locate import MissionNotFound, locate_mission
from tests.support.cli import run_main
from tests.support.paths import REPO_ROOT

ROOT = REPO_ROOT
SQUARE = ROOT / "config" / "missions" / "square.yaml"


@pytest.mark.parametrize(
    ("url", "why"),
    [
        ("foo", "absolute path"),
        ("tcp:", "expected HOST:PORT"),
        ("tcp:localhost", "expected HOST:PORT"),
        ("tcp:host:99999", "port 99999 is outside 1..65535"),
        ("udpout:host:0", "port 0 is outside 1..65535"),
        ("http://192.168.1.10:14550", "unknown scheme 'http'"),
        ("", "empty"),
        ("   ", "empty"),
        ("/dev/ttyACM0:12345", "not a standard serial rate"),
        ("/dev/ttyACM0:abc", "baud 'abc' is not a number"),  # was exit 6 with a run directory
    ],
)
def test_bad_connect_is_exit_2_before_anything_is_created(
    url: str, why: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    runs = tmp_path / "runs"
    code, _, err = run_main(
        ["run", "--mission", str(SQUARE), "--connect", url, "--run-dir", str(runs)], capsys
    )
    assert code == 2, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, lines
    assert lines[0].startswith("error: --connect: ")
    assert why in lines[0]
    assert "allowed forms: /dev/ttyACM0" in lines[0]
    assert not runs.exists()


def test_status_connect_is_validated_too(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run_main(["status", "--connect", "udpin:0.0.0.0"], capsys)
    assert code == 2 and err.startswith("error: --connect: ")


def test_sim_and_connect_exclude_each_other(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, _, err = run_main(
        ["run", "-m", str(SQUARE), "--sim", "--connect", "tcp:127.0.0.1:5760"], capsys
    )
    assert code == 2 and "exclude each other" in err


def test_bad_config_url_is_refused_at_load(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = tmp_path / "c.yaml"
    cfg.write_text("link:\n  url: tcp:127.0.0.1\n", encoding="utf-8")
    runs = tmp_path / "runs"
    code, _, err = run_main(
        ["run", "-m", str(SQUARE), "-c", str(cfg), "--run-dir", str(runs)], capsys
    )
    assert code == 2 and "link.url" in err and "expected HOST:PORT" in err
    assert not runs.exists()


def test_check_refuses_a_signing_key_file_run_could_not_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = tmp_path / "c.yaml"
    cfg.write_text(f"link:\n  signing_key_file: {tmp_path / 'nope.key'}\n", encoding="utf-8")
    code, out, err = run_main(["check", "-c", str(cfg), "-m", str(SQUARE)], capsys)
    assert code == 2, out + err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert lines == [
        f"error: {cfg}: link.signing_key_file: cannot read {tmp_path / 'nope.key'} "
        "(No such file or directory)"
    ]


@pytest.mark.parametrize(
    ("argv", "fragments"),
    [
        (["sim", "--speedup", "0"], ["--speedup", "greater than or equal to 0.1"]),
        (["sim", "--speedup", "50"], ["--speedup", "less than or equal to 20"]),  # as run's
        (["sim", "--seed", "-1"], ["--seed", "greater than or equal to 0"]),
        (["sim", "--duration", "0"], ["--duration must be > 0"]),
        (["sim", "--fault", "meteor@3"], ["unknown fault 'meteor'"]),
        (["sim", "--terrain", "lava"], ["--terrain", "lava"]),
        (["sim", "--speedup", "fast"], ["--speedup", "valid number"]),
        (["run", "-m", "x.yaml", "--sim-speedup", "0"], ["--sim-speedup"]),
        (["run", "--bogus"], ["No such option: --bogus"]),
        (["check", "--mission"], ["--mission"]),
    ],
)
def test_option_errors_are_one_line(
    argv: list[str], fragments: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    code, _, err = run_main(argv, capsys)
    assert code == 2, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, lines
    line = lines[0]
    assert line.startswith("error: ")
    assert "pydantic" not in line and "errors.pydantic.dev" not in line
    assert "validation error for" not in line and "╭" not in err
    for fragment in fragments:
        assert fragment in line, line


def test_version_and_help_still_exit_0(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run_main(["version"], capsys)
    assert code == 0 and out.startswith("helixd ")
    code, out, _ = run_main(["check", "--help"], capsys)
    assert code == 0 and "--mission" in out


# -- missions by name -----------------------------------------------------------------------------


def test_readme_command_works_from_the_repository_root(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(ROOT)
    code, out, err = run_main(["check", "--mission", "square.yaml"], capsys)
    assert code == 0, err
    assert "using config/missions/square.yaml" in err
    assert "mission : config/missions/square.yaml  OK" in out
    code, out, err = run_main(["check", "--mission", "hexagon"], capsys)  # suffix optional
    assert code == 0 and "config/missions/hexagon.yaml" in out


def test_a_path_that_exists_is_used_as_given(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "config" / "missions").mkdir(parents=True)
    (tmp_path / "config" / "missions" / "square.yaml").write_text("not: a mission\n")
    (tmp_path / "square.yaml").write_text(SQUARE.read_text(encoding="utf-8"), encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    code, out, err = run_main(["check", "-m", "square.yaml"], capsys)
    assert code == 0, err
    assert "using" not in err and "mission : square.yaml  OK" in out


def test_missing_mission_names_every_place_searched(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    runs = tmp_path / "runs"
    code, _, err = run_main(["run", "-m", "lawnmower.yaml", "--run-dir", str(runs)], capsys)
    assert code == 2
    assert (
        "lawnmower.yaml: mission file not found; looked for lawnmower.yaml, "
        "config/missions/lawnmower.yaml, /etc/helixd/missions/lawnmower.yaml" in err
    )
    assert not runs.exists()


def test_a_path_with_a_directory_is_not_searched(tmp_path: Path) -> None:
    with pytest.raises(MissionNotFound, match=r"file not found$"):
        locate_mission(tmp_path / "square.yaml")


def test_search_order(tmp_path: Path) -> None:
    first, second = tmp_path / "a", tmp_path / "b"
    first.mkdir()
    second.mkdir()
    (second / "m.yaml").write_text("x")
    found = locate_mission(Path("m.yaml"), (first, second))
    assert found.path == second / "m.yaml" and found.searched
    (first / "m.yml").write_text("x")
    assert locate_mission(Path("m"), (first, second)).path == first / "m.yml"


def _free_port(kind: socket.SocketKind) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.mark.parametrize(
    ("scheme", "kind", "why"),
    [
        ("tcp", socket.SOCK_STREAM, "connection refused"),
        ("udpout", socket.SOCK_DGRAM, "no HEARTBEAT"),
    ],
)
def test_a_link_never_made_is_exit_6_with_one_line_and_no_run_directory(
    scheme: str,
    kind: socket.SocketKind,
    why: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    url = f"{scheme}:127.0.0.1:{_free_port(kind)}"  # bound and closed: nobody there
    config = tmp_path / "helixd.yaml"
    config.write_text("startup:\n  connect_timeout_s: 1.0\n")
    runs = tmp_path / "runs"
    argv = ["run", "--mission", str(SQUARE), "--connect", url, "--run-dir", str(runs)]
    code, out, err = run_main([*argv, "--config", str(config)], capsys)
    assert code == 6, err
    errors = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert errors == [errors[0]] and errors[0].startswith(f"error: could not connect to {url}: ")
    assert why in errors[0]
    assert "Traceback" not in out + err
    assert "link_lost" not in out + err and "run directory" not in err
    assert not runs.exists()
