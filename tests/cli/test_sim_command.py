"""``helixd sim``'s defaults: low pose noise unless the command line or the simulator YAML
says otherwise, and ``sim -h`` says so (the thesis's noise moved the
reported position 0.6-1.0 m while the rover sat in HOLD, and nothing said it was chosen)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from helixd.cli.app import main
from helixd.sim.sim_config import NoiseLevel, SimConfig
from tests.support.cli import run_main


class Started(Exception):
    """Raised in place of running the simulator."""


def started_config(monkeypatch: pytest.MonkeyPatch, argv: list[str]) -> SimConfig:
    """The SimConfig ``helixd sim argv`` would run the simulator with."""
    import helixd.cli.sim_command

    seen: list[SimConfig] = []

    def run_sim(links: list[str], config: SimConfig, *_: Any) -> None:
        seen.append(config)
        raise Started

    monkeypatch.setattr(helixd.cli.sim_command, "run_sim", run_sim)
    with pytest.raises(Started):
        main(["sim", *argv])
    (cfg,) = seen
    return cfg


def test_sim_defaults_to_low_noise(monkeypatch: pytest.MonkeyPatch) -> None:
    assert started_config(monkeypatch, []).noise is NoiseLevel.LOW


def test_sim_noise_from_the_command_line_or_the_yaml(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    assert started_config(monkeypatch, ["--noise", "thesis"]).noise is NoiseLevel.THESIS
    yaml_file = tmp_path / "sim.yaml"
    yaml_file.write_text("noise: thesis\n", encoding="utf-8")
    assert started_config(monkeypatch, ["--config", str(yaml_file)]).noise is NoiseLevel.THESIS
    other = tmp_path / "other.yaml"
    other.write_text("speedup: 2.0\n", encoding="utf-8")  # no noise: the command's default
    assert started_config(monkeypatch, ["--config", str(other)]).noise is NoiseLevel.LOW
    both = ["--config", str(yaml_file), "--noise", "none"]
    assert started_config(monkeypatch, both).noise is NoiseLevel.NONE


def test_sim_help_states_the_noise_default(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run_main(["sim", "-h"], capsys)
    assert code == 0
    flat = " ".join(out.split())
    assert "--noise" in flat and "else low" in flat and "thesis" in flat
