"""``run|serve --sim --sim-bathymetry FILE`` and ``sim --bathymetry FILE``: the pond's bottom
reaches the simulator; a bad file is a usage error naming the option, the file and the field."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.cli.app import main
from tests.support.cli import run_main
from tests.support.paths import REPO_ROOT
from tests.support.simcore import EmbeddedStart, capture_embedded_start

POND = REPO_ROOT / "config/maps/pond-bathymetry.yaml"


def test_run_sim_bathymetry_reaches_the_embedded_simulator(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    seen = capture_embedded_start(monkeypatch)
    with pytest.raises(EmbeddedStart):
        main(["run", "--sim", "--sim-bathymetry", str(POND), "--mission", "square"])
    (sim,) = seen
    assert sim.bathymetry is not None and sim.bathymetry.shape == (45, 35)


def test_sim_bathymetry_refusals(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(POND.read_text().replace("cell_m: 1.0", "cell_m: -1"), encoding="utf-8")
    for argv in (
        ["run", "--sim", "--sim-bathymetry", str(bad), "--mission", "square"],
        ["serve", "--sim", "--sim-bathymetry", str(bad)],
        ["sim", "--bathymetry", str(bad)],
    ):
        code, _, err = run_main(argv, capsys)
        assert code == 2, argv
        assert f"{bad}: cell_m" in err, err
    code, _, err = run_main(["run", "--sim-bathymetry", str(POND), "--mission", "square"], capsys)
    assert code == 2 and "error: --sim-bathymetry needs --sim" in err
