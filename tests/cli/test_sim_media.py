"""``run --sim --sim-media FILE`` and ``sim --media FILE``: the map reaches the simulator; a
bad map is a usage error naming the option, the file and the feature."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.base.media import Medium
from helixd.cli.app import main
from tests.support.cli import run_main
from tests.support.paths import REPO_ROOT
from tests.support.simcore import EmbeddedStart, capture_embedded_start

POND = REPO_ROOT / "config/maps/pond-media.geojson"
BAD = '{"type": "FeatureCollection", "features": [{"type": "Feature", "properties": {"medium": "lava"}, "geometry": null}]}'  # noqa: E501


# the verb and its other options: ``run`` with a mission, and the README's one-machine serve
# trial, amphibious (``serve --sim --sim-media FILE``)
VERBS = {"run": ["run", "--mission", "square"], "serve": ["serve", "--mode", "roll"]}


@pytest.mark.parametrize("verb", VERBS)
def test_run_and_serve_sim_media_reach_the_embedded_simulator(
    verb: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    seen = capture_embedded_start(monkeypatch)
    with pytest.raises(EmbeddedStart):
        main([*VERBS[verb], "--sim", "--sim-media", str(POND)])
    (sim,) = seen
    assert sim.media is not None and sim.media.source == str(POND)
    assert sim.media.areas[1].medium is Medium.WATER


@pytest.mark.parametrize("verb", VERBS)
def test_run_and_serve_sim_media_refusals(
    verb: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.geojson"
    bad.write_text(BAD, encoding="utf-8")
    code, _, err = run_main([*VERBS[verb], "--sim", "--sim-media", str(bad)], capsys)
    assert code == 2
    assert f"error: --sim-media: {bad}: features.0.properties.medium: 'lava'" in err
    code, _, err = run_main([*VERBS[verb], "--sim-media", str(POND)], capsys)
    assert code == 2 and "error: --sim-media needs --sim" in err


def test_sim_media_refusal(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.geojson"
    bad.write_text(BAD, encoding="utf-8")
    code, _, err = run_main(["sim", "--media", str(bad), "--duration", "1"], capsys)
    assert code == 2
    assert f"error: --media: {bad}: features.0.properties.medium: 'lava'" in err
