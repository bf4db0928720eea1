"""helixd.recorder.resume_dir: where the interrupted run left the rover (flight.csv's tail)."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.recorder.resume_dir import TAIL_BYTES, last_pose_ned, run_numbering
from tests.support.recorder_runs import synth_run

HEAD = "# comment\nt_boot_s,north_m,east_m,yaw_ned_rad,x_m\n"


def test_the_last_finite_pose_of_a_real_run(tmp_path: Path) -> None:
    run_dir, _ = synth_run(tmp_path)
    pose = last_pose_ned(run_dir / "flight.csv")
    assert pose is not None
    rows = (run_dir / "flight.csv").read_text().splitlines()
    head = rows[1].split(",")
    last = rows[-1].split(",")
    assert pose[0] == pytest.approx(float(last[head.index("north_m")]))
    assert pose[1] == pytest.approx(float(last[head.index("east_m")]))


def test_torn_and_non_finite_rows_are_skipped_and_only_the_tail_is_read(tmp_path: Path) -> None:
    path = tmp_path / "flight.csv"
    filler = "".join(f"{i},1.0,2.0,0.5,0\n" for i in range(TAIL_BYTES // 10))
    path.write_text(HEAD + filler + "9,3.0,4.0,0.25,0\n9,nan,4.0,0.25,0\n9,5.0", encoding="utf-8")
    assert last_pose_ned(path) == (3.0, 4.0, 0.25)


def test_nothing_usable_is_none(tmp_path: Path) -> None:
    assert last_pose_ned(tmp_path / "missing.csv") is None
    path = tmp_path / "flight.csv"
    path.write_text("# c\nt_boot_s,x_m\n1,2\n", encoding="utf-8")  # no NED columns
    assert last_pose_ned(path) is None


def test_numbering_without_inputs_json_starts_at_1(tmp_path: Path) -> None:
    assert run_numbering(tmp_path, [True, False]).label(1) == "1/1"
