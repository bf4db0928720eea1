"""The ground profile file: written whole and read back exactly; a hostile or edited-wrong file
is refused naming the file and the field."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.base.media import Medium
from helixd.base.plan import MotionMode
from helixd.control.ground_fit import AxisSums, CellSums
from helixd.files.models import ConfigFileError
from helixd.recorder.ground_profile import GroundProfile, read_profile, run_origin, write_profile

CELL = CellSums(
    roll=AxisSums(1.5, 1.2, 1.0, 30.0, 1500), metres=12.5, energy_j=2400.0, runs=("r1", "r2")
)


def test_a_profile_round_trips_and_a_missing_file_is_an_empty_profile(tmp_path: Path) -> None:
    path = tmp_path / "state" / "ground-profile.yaml"
    assert read_profile(path).cells == {}
    profile = GroundProfile(
        {(Medium.HARD, MotionMode.ROLL): CELL}, {(Medium.MUD, MotionMode.SCROLL, "scroll"): 0.7}
    )
    write_profile(path, profile)
    assert path.read_text().startswith("# helixd ground profile")
    back = read_profile(path)
    assert back.cells == profile.cells and back.pins == profile.pins
    assert not path.with_name(path.name + ".tmp").exists()


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("cells:\n- {medium: lava, mode: roll}\n", "cells.0.medium: Input should be"),
        (
            "cells:\n- {medium: hard, mode: roll, metres: .nan}\n",
            "cells.0.metres: Input should be a finite",
        ),
        (
            "cells:\n- {medium: hard, mode: roll, roll: {s_uu: -1}}\n",
            "cells.0.roll.s_uu: Input should be greater",
        ),
        (
            "pins:\n- {medium: mud, mode: scroll, axis: heave, fraction: 0.5}\n",
            "pins.0.axis: String should match",
        ),
        (
            "pins:\n- {medium: mud, mode: scroll, axis: roll, fraction: 2}\n",
            "pins.0.fraction: Input should be less",
        ),
        ("version: 9\n", "version: Input should be less than or equal to 1"),
        ("bogus: 1\n", "bogus: unknown key"),
        (
            "cells:\n- {medium: hard, mode: roll}\n- {medium: hard, mode: roll}\n",
            "hard/roll given twice",
        ),
    ],
)
def test_a_bad_profile_is_refused_naming_the_field(
    tmp_path: Path, text: str, expected: str
) -> None:
    path = tmp_path / "ground-profile.yaml"
    path.write_text(text)
    with pytest.raises(ConfigFileError) as err:
        read_profile(path)
    assert any(expected in line and line.startswith(str(path)) for line in err.value.problems), (
        err.value.problems
    )


def test_the_runs_origin_comes_from_its_summary(tmp_path: Path) -> None:
    assert run_origin(tmp_path) is None
    (tmp_path / "summary.json").write_text('{"origin_latlon_deg": [53.5, -113.5]}')
    assert run_origin(tmp_path) == (53.5, -113.5)
    (tmp_path / "summary.json").write_text('{"origin_latlon_deg": [NaN, 1]}')
    assert run_origin(tmp_path) is None
