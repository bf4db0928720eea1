"""``--sim-ground FILE`` for ``run --sim``, ``sim`` and ``plant``: the ground file reaches the
simulator; a bad one is a usage error naming the option, the file, the field and the range."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.cli.app import main
from helixd.cli.plant import plant_config
from helixd.plant.ground import TerrainTable
from tests.support.cli import run_main
from tests.support.simcore import EmbeddedStart, capture_embedded_start

SITE = "mud:\n  scroll_efficiency: 0.7\nhard: {roll_efficiency: 0.5, power_w: 150}\n"
BAD = "mud:\n  grip: 1\nsand: {yaw_efficiency: 1.5}\n"


def site(tmp_path: Path, text: str = SITE) -> Path:
    path = tmp_path / "site-ground.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def test_run_sim_ground_reaches_the_embedded_simulator(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    seen = capture_embedded_start(monkeypatch)
    with pytest.raises(EmbeddedStart):
        main(["run", "--sim", "--sim-ground", str(site(tmp_path)), "--mission", "square"])
    (sim,) = seen
    assert sim.terrains.mud.scroll_efficiency == 0.7
    assert (sim.terrains.hard.roll_efficiency, sim.terrains.hard.power_w) == (0.5, 150.0)
    assert sim.terrains.water == TerrainTable().water  # not named: the built-in row
    assert sim.traction().roll_efficiency == 0.5  # --sim-terrain hard: the file's hard ground


def test_run_sim_ground_refusals(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = site(tmp_path, BAD)
    code, _, err = run_main(
        ["run", "--sim", "--sim-ground", str(bad), "--mission", "square"], capsys
    )
    assert code == 2
    assert f"error: --sim-ground: {bad}: mud.grip: unknown key" in err
    assert f"error: --sim-ground: {bad}: sand.yaw_efficiency: " in err
    assert "allowed range 0.0 .. 1.0" in err
    good = site(tmp_path)
    code, _, err = run_main(["run", "--sim-ground", str(good), "--mission", "square"], capsys)
    assert code == 2 and "error: --sim-ground needs --sim" in err


def test_sim_and_plant_take_a_ground_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, _, err = run_main(
        ["sim", "--ground", str(site(tmp_path, BAD)), "--duration", "1"], capsys
    )
    assert code == 2 and "mud.grip: unknown key" in err
    cfg = plant_config(None, None, None, None, site(tmp_path))
    assert cfg.terrains.mud.scroll_efficiency == 0.7 and cfg.terrains.hard.power_w == 150.0
