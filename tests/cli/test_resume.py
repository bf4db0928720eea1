"""`helixd run --resume RUN_DIR` refusals: one `error:` line each and exit 2, before any link
is opened (the URL in the config points nowhere)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from helixd.base.run_files import INPUTS_FILE
from helixd.cli.app import main
from helixd.mission.formats import mission_to_yaml
from helixd.mission.model import Mission
from helixd.mission.resume import fresh_inputs
from helixd.prepare.inputs import config_sha256

LANE = Mission.model_validate(
    {
        "name": "lane",
        "mode": "roll",
        "frame": "local_ned",
        "waypoints": [{"north": 5.0, "east": 0.0}, {"north": 10.0, "east": 0.0}],
    }
)


def _run_dir(tmp_path: Path, mission: Mission = LANE, reached: int = 1) -> Path:
    d = tmp_path / "run"
    d.mkdir()
    text = mission_to_yaml(mission)
    (d / "mission.yaml").write_text(text)
    (d / INPUTS_FILE).write_text(fresh_inputs(text, config_sha256(None), mission).to_json())
    lines = [{"event": "run_started"}] + [
        {"event": "waypoint_reached", "index": i} for i in range(reached)
    ]
    (d / "events.jsonl").write_text("".join(json.dumps(e) + "\n" for e in lines))
    return d


def _refused(capsys: pytest.CaptureFixture[str], *argv: str) -> str:
    with pytest.raises(SystemExit) as exc:
        main(["run", *argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert exc.value.code == 2, err
    assert len(err) == 1 and err[0].startswith("error: "), err
    return err[0]


def test_missing_run_dir(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert "not a run directory" in _refused(capsys, "--resume", str(tmp_path / "nope"))


def test_old_run_dir_without_hashes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    d = _run_dir(tmp_path)
    (d / INPUTS_FILE).unlink()
    assert "no inputs.json" in _refused(capsys, "--resume", str(d))


def test_changed_config(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    d = _run_dir(tmp_path)
    cfg = tmp_path / "other.yaml"
    cfg.write_text("control:\n  max_speed_mps: 0.3\n")
    line = _refused(capsys, "--resume", str(d), "--config", str(cfg))
    assert "config changed" in line


def test_edited_mission_in_run_dir(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    d = _run_dir(tmp_path)
    (d / "mission.yaml").write_text((d / "mission.yaml").read_text().replace("10.0", "11.0"))
    assert "changed since" in _refused(capsys, "--resume", str(d))


def test_other_mission_given(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    d = _run_dir(tmp_path)
    other = tmp_path / "other.yaml"
    other.write_text(mission_to_yaml(LANE).replace("10.0", "12.0"))
    assert "--mission differs" in _refused(capsys, "--resume", str(d), "--mission", str(other))


def test_completed_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    d = _run_dir(tmp_path, reached=2)
    (d / "summary.json").write_text(json.dumps({"completed": True}))
    assert "completed already" in _refused(capsys, "--resume", str(d))


def test_truncated_garbage_events(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    d = _run_dir(tmp_path)
    (d / "events.jsonl").write_bytes(b'{"event": "run_sta\x00\xff garbage')
    assert "corrupt event log" in _refused(capsys, "--resume", str(d))


def test_start_frame_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    square = Mission.model_validate(
        {"name": "sq", "mode": "roll", "frame": "start", "waypoints": [{"x": 5, "y": 0}] * 1}
    )
    assert "start-frame" in _refused(capsys, "--resume", str(_run_dir(tmp_path, square)))


def test_flags_that_change_the_mission(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    d = _run_dir(tmp_path)
    assert "--mode" in _refused(capsys, "--resume", str(d), "--mode", "scroll")
