"""Every ``helixd`` command in README.md's ``sh`` blocks runs as written on a fresh clone.

The command line runs in this process. Offline commands (``check``, ``mission
convert|survey``, ``--version``, ``-h``) are run from a scratch directory that sees the
checkout's ``config/`` and ``tests/`` (so what they write lands there), and must exit 0.
Commands that need an autopilot or fly are checked to parse: their sub-command has ``--help``
and names every option used. Every file a command names exists in the checkout, unless it is
an output or a placeholder (``<run>``, ``URL``, ``DIR``, ``runs/``).
"""

from __future__ import annotations

import itertools
import re
import shlex
from pathlib import Path

import pytest

from tests.support.cli import run_main
from tests.support.paths import REPO_ROOT

SH_BLOCK = re.compile(r"^\s*```sh\n(.*?)^\s*```", re.MULTILINE | re.DOTALL)
RUNNABLE = (("check",), ("mission", "convert"), ("mission", "survey"))
# options whose value the command writes (an output, not an input that must exist)
OUTPUT_OPTIONS = {"-o", "--output", "--plot"}
PLACEHOLDERS = ("<", "URL", "DIR", "runs/", "/dev/", "/etc/", ":", "…", "|", "NAME")
FILE_LIKE = re.compile(r"(/|\.(ya?ml|plan|waypoints|geojson|kml|png|pgm)$)")


def _commands() -> list[str]:
    text = (REPO_ROOT / "README.md").read_text(encoding="utf-8")
    found: list[str] = []
    for block in SH_BLOCK.findall(text):
        for line in block.splitlines():
            line = re.sub(r"\s#\s.*$|\s{2,}#.*$", "", line).strip()
            for part in line.split(";"):
                part = part.strip()
                if not part.startswith("helixd"):
                    continue
                # a synopsis (`mission survey|convert …`): one command per alternative
                words = part.replace("…", "").split()
                alts = [w for w in words if "|" in w and not w.startswith("-")]
                if alts:
                    i = words.index(alts[0])
                    found += [" ".join([*words[:i], alt]) for alt in alts[0].split("|")]
                else:
                    found.append(part)
    return found


COMMANDS = _commands()


def _argv(command: str) -> list[str]:
    return shlex.split(command.replace("[", "").replace("]", ""))[1:]


def _sub(argv: list[str]) -> tuple[str, ...]:
    words: list[str] = []
    for word in argv:
        if word.startswith("-") or len(words) == 2:
            break
        words.append(word)
        if words[0] not in ("mission", "autopilot"):
            break
    return tuple(words)


def _runnable(argv: list[str]) -> bool:
    if argv in (["--version"], ["-h"], ["--help"]) or argv[-1:] in (["-h"], ["--help"]):
        return True
    sub = _sub(argv)  # a bare `mission convert` is a synopsis: only parsed
    return sub in RUNNABLE and len(argv) > len(sub) and "--connect" not in argv


def test_readme_has_commands() -> None:
    assert len(COMMANDS) >= 20, COMMANDS


@pytest.mark.parametrize("command", COMMANDS)
def test_files_it_names_exist(command: str) -> None:
    argv = _argv(command)
    sub = _sub(argv)
    outputs: set[str] = set()
    for opt, value in itertools.pairwise(argv):
        if opt in OUTPUT_OPTIONS:
            outputs.add(value)
    positional = [a for a in argv[len(sub) :] if not a.startswith("-")]
    if sub == ("mission", "convert") and len(positional) >= 2:
        outputs.add(positional[1])
    if sub == ("mission", "download") and positional:
        outputs.add(positional[-1])
    missing = []
    for i, word in enumerate(argv):
        if word in outputs or word.startswith("-") or any(p in word for p in PLACEHOLDERS):
            continue
        prev = argv[i - 1] if i else ""
        if prev == "--mission":  # a path, or a bare name looked up in config/missions/
            places = (
                REPO_ROOT / word,
                *(REPO_ROOT / "config/missions" / n for n in (word, f"{word}.yaml")),
            )
            if word != "autopilot" and not any(p.exists() for p in places):
                missing.append(word)
            continue
        if FILE_LIKE.search(word) and not (REPO_ROOT / word).exists():
            missing.append(word)
    assert not missing, f"{command}: no such file in the checkout: {missing}"


@pytest.mark.parametrize("command", [c for c in COMMANDS if _runnable(_argv(c))])
def test_offline_command_runs(
    command: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """The real command line, in this process, from a scratch directory."""
    for name in ("config", "tests"):
        (tmp_path / name).symlink_to(REPO_ROOT / name)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "200")
    monkeypatch.setenv("NO_COLOR", "1")
    code, out, err = run_main(_argv(command), capsys)
    assert code == 0, f"{command}\n{out[-3000:]}\n{err[-3000:]}"


@pytest.mark.parametrize("command", [c for c in COMMANDS if not _runnable(_argv(c))])
def test_online_command_parses(
    command: str, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The real command line, in this process (its ``--help`` needs no autopilot)."""
    monkeypatch.setenv("COLUMNS", "200")
    monkeypatch.setenv("NO_COLOR", "1")
    argv = _argv(command)
    sub = list(_sub(argv))
    code, out, err = run_main([*sub, "--help"], capsys)
    assert code == 0, f"{command}: {' '.join(sub)} --help\n{err[-2000:]}"
    options = {a.split("=")[0] for a in argv if a.startswith("-") and a not in ("-h", "--help")}
    unknown = sorted(
        o for o in options if not re.search(rf"(?<![\w-]){re.escape(o)}(?![\w-])", out)
    )
    assert not unknown, f"{command}: not in `helixd {' '.join(sub)} --help`: {unknown}"


TOP_DIRS = ("config", "tests", "tools", "helixd", "docs", "systemd", "autopilot")
PATTERN_PATHS = {"helixd/x/y.py", "tests/x/test_y.py"}  # the layout's naming rule


def test_paths_in_the_text_exist() -> None:
    """Every `path` in the README's text under one of the checkout's folders exists."""
    text = (REPO_ROOT / "README.md").read_text(encoding="utf-8")
    spans = set(re.findall(r"`([^`\s]+)`", text)) - PATTERN_PATHS
    paths = [s for s in spans if s.split("/")[0] in TOP_DIRS and "/" in s]
    missing = sorted(p for p in paths if not list(REPO_ROOT.glob(p.rstrip("/"))))
    assert paths and not missing, missing
