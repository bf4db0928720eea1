"""The house's rooms stay small enough to read, over every module of ``helixd/``:

* no function (methods and nested ones too) over :data:`MAX_FUNCTION_LINES` lines, ``def`` to
  its last line: a function that long is several steps that want names;
* no module over :data:`MAX_MODULE_LINES` lines: a module that long holds several concerns;
* no package over :data:`MAX_PACKAGE_MODULES` modules (``__init__.py`` aside; a subpackage
  counts on its own): a package that big is several rooms.

Each rule is checked on a small synthetic tree too, so a checker that sees nothing fails.
"""

from __future__ import annotations

import ast
from pathlib import Path

from tests.support.paths import REPO_ROOT

PACKAGE = REPO_ROOT / "helixd"
MAX_FUNCTION_LINES = 80
MAX_MODULE_LINES = 800
MAX_PACKAGE_MODULES = 20


def _shown(path: Path, root: Path) -> str:
    """``helixd/…``: from the folder holding ``root``."""
    return str(path.relative_to(root.parent))


def _modules(root: Path) -> list[Path]:
    return sorted(p for p in root.rglob("*.py") if "__pycache__" not in p.parts)


def long_functions(root: Path, limit: int = MAX_FUNCTION_LINES) -> list[str]:
    """``file:line name (N lines)`` for each function under ``root`` whose ``def`` to last
    line spans more than ``limit`` lines."""
    found = []
    for path in _modules(root):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                lines = (node.end_lineno or node.lineno) - node.lineno + 1
                if lines > limit:
                    found.append(f"{_shown(path, root)}:{node.lineno} {node.name} ({lines} lines)")
    return found


def long_modules(root: Path, limit: int = MAX_MODULE_LINES) -> list[str]:
    """``file (N lines)`` for each module under ``root`` longer than ``limit`` lines."""
    found = []
    for path in _modules(root):
        lines = len(path.read_text(encoding="utf-8").splitlines())
        if lines > limit:
            found.append(f"{_shown(path, root)} ({lines} lines)")
    return found


def big_packages(root: Path, limit: int = MAX_PACKAGE_MODULES) -> list[str]:
    """``package/ (N modules)`` for each directory under ``root`` (``root`` included) holding
    more than ``limit`` modules of its own (``__init__.py`` and subpackages' modules aside)."""
    found = []
    for folder in sorted({p.parent for p in _modules(root)}):
        count = sum(1 for p in folder.glob("*.py") if p.name != "__init__.py")
        if count > limit:
            found.append(f"{_shown(folder, root)}/ ({count} modules)")
    return found


def test_no_function_over_80_lines() -> None:
    offenders = long_functions(PACKAGE)
    assert offenders == [], "\n".join(offenders)


def test_no_module_over_800_lines() -> None:
    offenders = long_modules(PACKAGE)
    assert offenders == [], "\n".join(offenders)


def test_no_package_over_20_modules() -> None:
    offenders = big_packages(PACKAGE)
    assert offenders == [], "\n".join(offenders)


def _probe(tmp_path: Path, text: str) -> Path:
    """A synthetic ``helixd/`` holding ``probe.py`` with ``text``."""
    root = tmp_path / "helixd"
    root.mkdir()
    (root / "probe.py").write_text(text)
    return root


def test_the_function_checker_counts_from_def_to_the_last_line(tmp_path: Path) -> None:
    body = "".join(f"    x{i} = {i}\n" for i in range(80))
    root = _probe(tmp_path, f"def long():\n{body}\nclass C:\n    def short(self):\n        pass\n")
    assert long_functions(root) == ["helixd/probe.py:1 long (81 lines)"]
    assert long_functions(root, limit=81) == []


def test_the_function_checker_sees_methods_and_nested_functions(tmp_path: Path) -> None:
    body = "".join(f"            x{i} = {i}\n" for i in range(80))
    root = _probe(tmp_path, f"class C:\n    async def outer(self):\n        def inner():\n{body}")
    assert long_functions(root) == [
        "helixd/probe.py:2 outer (82 lines)",
        "helixd/probe.py:3 inner (81 lines)",
    ]


def test_the_module_checker_names_a_long_module(tmp_path: Path) -> None:
    root = tmp_path / "helixd"
    sub = root / "pkg"
    sub.mkdir(parents=True)
    (sub / "long.py").write_text("x = 1\n" * 801)
    (sub / "short.py").write_text("x = 1\n" * 800)
    assert long_modules(root) == ["helixd/pkg/long.py (801 lines)"]
    assert long_modules(root, limit=801) == []


def test_the_package_checker_counts_each_folder_on_its_own(tmp_path: Path) -> None:
    root = tmp_path / "helixd"
    big, nested = root / "big", root / "big" / "nested"
    nested.mkdir(parents=True)
    for folder, n in ((root, 2), (big, 21), (nested, 20)):
        (folder / "__init__.py").write_text("")
        for i in range(n):
            (folder / f"m{i}.py").write_text("")
    assert big_packages(root) == ["helixd/big/ (21 modules)"]
    assert big_packages(root, limit=21) == []
