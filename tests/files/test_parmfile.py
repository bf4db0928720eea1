"""ArduPilot parameter files: read as ArduPilot and the ground stations write them, refused
line by line when they are not."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from helixd.files.parmfile import MAX_FILE_BYTES, ParmFileError, load_parm, parse_parm


def test_names_and_values_in_file_order_with_comments_and_commas() -> None:
    text = "# a comment\nSERVO1_FUNCTION 51\n\nFS_THR_VALUE,960  # trailing\n"
    text += "RC_OVERRIDE_TIME\t3.5\n"
    got = parse_parm(text, "x.parm")
    assert list(got.items()) == [
        ("SERVO1_FUNCTION", 51.0),
        ("FS_THR_VALUE", 960.0),
        ("RC_OVERRIDE_TIME", 3.5),
    ]


def test_every_bad_line_is_named_with_its_number() -> None:
    text = "GOOD 1\nlower 2\nNOVALUE\nFS_ACTION two\nBIG inf\nGOOD 3\nTOO_LONG_NAME_XXXX 1\n"
    with pytest.raises(ParmFileError) as err:
        parse_parm(text, "h.parm")
    problems = err.value.problems
    assert len(problems) == 6
    assert problems[0].startswith("h.parm:2: 'lower' is not a parameter name")
    assert problems[1].startswith("h.parm:3: expected 'NAME VALUE'")
    assert problems[2] == "h.parm:4: FS_ACTION = 'two' is not a number"
    assert problems[3] == "h.parm:5: BIG = 'inf' is not a finite number"
    assert problems[4] == "h.parm:6: GOOD set again (first on line 1)"
    assert problems[5].startswith("h.parm:7: 'TOO_LONG_NAME_XXXX'")


def test_a_file_too_large_or_not_utf8_is_refused(tmp_path: Path) -> None:
    big = tmp_path / "big.parm"
    big.write_bytes(b"#" * (MAX_FILE_BYTES + 1))
    with pytest.raises(ParmFileError, match="larger than"):
        load_parm(big)
    latin = tmp_path / "latin.parm"
    latin.write_bytes(b"# caf\xe9\nA 1\n")
    with pytest.raises(ParmFileError, match=r"not UTF-8 \(byte 5\)"):
        load_parm(latin)
    with pytest.raises(ParmFileError, match="cannot read"):
        load_parm(tmp_path / "missing.parm")


@given(st.text(max_size=200))
def test_any_text_gives_values_or_named_problems(text: str) -> None:
    try:
        got = parse_parm(text, "f.parm")
    except ParmFileError as exc:
        assert exc.problems and all(p.startswith("f.parm:") for p in exc.problems)
        return
    assert all(isinstance(v, float) for v in got.values())
