"""The documentation lives in the repository and cites nothing outside it.

Every tracked text file under helixd/, tests/, tools/, docs/, config/, systemd/ and autopilot/,
and README.md and the Makefile, states its facts or points into docs/: no citation of an
outside design document and no ticket number. Every relative link in README.md and docs/*.md
resolves to a file (and, with a ``#fragment``, to a heading of that file).
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

from tests.support.paths import REPO_ROOT

SCANNED_DIRS = ("helixd", "tests", "tools", "docs", "config", "systemd", "autopilot")
SCANNED_FILES = ("README.md", "Makefile")
# bench/results/ is generated output (its generators, tools/bench_*.py, are scanned) and is not
# listed; files that are not UTF-8 text are skipped.
THIS_FILE = Path(__file__).resolve()

# Split so that this file does not match itself.
_DESIGN = "DES" + "IGN"
CITATIONS = (
    re.compile(rf"\b{_DESIGN}\.md\b"),
    re.compile(rf"\b{_DESIGN}\s*§"),
    re.compile(r"(?<![a-z])(?:issue|ticket)s?[\s_]*#?\d+", re.IGNORECASE),
    re.compile(r"§\s?\d"),
)
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)")
HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*#*\s*$", re.MULTILINE)
FENCE = re.compile(r"^```.*?^```", re.MULTILINE | re.DOTALL)


def _tracked_files() -> list[Path]:
    try:
        out = subprocess.run(
            ["git", "ls-files", "-z", "--", *SCANNED_DIRS, *SCANNED_FILES],
            cwd=REPO_ROOT,
            capture_output=True,
            check=True,
        ).stdout
        names = [n for n in out.decode().split("\0") if n]
    except (OSError, subprocess.CalledProcessError):  # not a git checkout: walk the tree
        names = [
            str(p.relative_to(REPO_ROOT))
            for d in SCANNED_DIRS
            for p in (REPO_ROOT / d).rglob("*")
            if p.is_file() and "__pycache__" not in p.parts
        ] + [f for f in SCANNED_FILES if (REPO_ROOT / f).is_file()]
    return [REPO_ROOT / n for n in sorted(names) if (REPO_ROOT / n).resolve() != THIS_FILE]


def _text(path: Path) -> str | None:
    try:
        return path.read_text(encoding="utf-8")
    except (UnicodeDecodeError, FileNotFoundError):
        return None


def citations(text: str) -> list[str]:
    """The citations of outside documents or tickets in ``text``, as found."""
    return [m.group(0) for pattern in CITATIONS for m in pattern.finditer(text)]


def test_the_patterns_catch_citations_and_spare_mavlink_names() -> None:
    design = _DESIGN
    assert citations(f"see {design}.md") and citations(f"({design} §3)")
    assert citations("target restated in issue 22") and citations("(Issue 14/16)")
    assert citations("issues 6/10") and citations("ticket #12") and citations("thesis §3.7")
    assert citations("def test_issue_6_10_nan_pose()")
    assert not citations("MISSION_ITEM_INT, MISSION_ISSUED, last #25 +50.0 s, the issue's owner")
    assert not citations("designed path, design choices, §-less text")


def test_no_file_cites_an_outside_document_or_a_ticket() -> None:
    hits = []
    for path in _tracked_files():
        text = _text(path)
        if text is None:
            continue
        for number, line in enumerate(text.splitlines(), 1):
            for found in citations(line):
                hits.append(f"{path.relative_to(REPO_ROOT)}:{number}: {found!r}")
    assert not hits, "state the fact or point into docs/ instead:\n" + "\n".join(hits)


def _slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"[`*_]", "", heading.strip().lower())
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def _anchors(path: Path) -> set[str]:
    text = FENCE.sub("", path.read_text(encoding="utf-8"))
    return {_slug(h) for h in HEADING.findall(text)}


def _markdown_pages() -> list[Path]:
    return [REPO_ROOT / "README.md", *sorted((REPO_ROOT / "docs").glob("*.md"))]


@pytest.mark.parametrize("page", _markdown_pages(), ids=lambda p: p.name)
def test_every_relative_link_resolves(page: Path) -> None:
    text = FENCE.sub("", page.read_text(encoding="utf-8"))
    broken = []
    for target in LINK.findall(text):
        if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:
            continue
        name, _, fragment = target.partition("#")
        dest = (page.parent / name).resolve() if name else page
        if not dest.exists():
            broken.append(f"{target}: no such file")
        elif fragment and dest.suffix == ".md" and fragment not in _anchors(dest):
            broken.append(f"{target}: no heading #{fragment}")
    assert not broken, f"{page.relative_to(REPO_ROOT)}: " + "; ".join(broken)


def test_the_readme_points_to_the_maintainers_pages() -> None:
    readme = (REPO_ROOT / "README.md").read_text(encoding="utf-8")
    for page in ("docs/physics.md", "docs/ardupilot.md", "docs/architecture.md"):
        assert f"({page}" in readme
    assert "(docs/measurements.md" in readme
