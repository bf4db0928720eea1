"""``run --sim``: the embedded simulator comes with helixd-guard installed, guarding the
config's scroll outputs, its timeout 0.5 s of wall time at any speed-up."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.cli.app import main
from helixd.cli.simulated import embedded_guard
from helixd.config import HelixdConfig
from tests.support.simcore import EmbeddedStart, capture_embedded_start


def test_run_sim_installs_the_guard_for_the_config(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    seen = capture_embedded_start(monkeypatch)
    cfg = tmp_path / "servo.yaml"
    cfg.write_text(
        "actuation:\n  backend: servo\n  channels:\n"
        + "".join(f"  - channel: {n}\n" for n in (5, 6, 7, 8)),
        encoding="utf-8",
    )
    with pytest.raises(EmbeddedStart):
        main(["run", "--sim", "--sim-speedup", "4", "--mission", "square", "--config", str(cfg)])
    (sim,) = seen
    assert sim.guard_installed
    assert sim.guard_params == {
        "HXG_TIMEOUT": 2.0,
        "HXG_CHAN1": 5.0,
        "HXG_CHAN2": 6.0,
        "HXG_CHAN3": 7.0,
        "HXG_CHAN4": 8.0,
    }


def test_embedded_guard_timeout_is_clamped_and_high_channels_are_left_out() -> None:
    cfg = HelixdConfig.model_validate(
        {"actuation": {"channels": [{"channel": c} for c in (1, 2, 17, 18)]}}
    )
    got = embedded_guard(cfg, 20.0)
    assert got["HXG_TIMEOUT"] == 10.0  # the script's clamp
    assert [got[f"HXG_CHAN{i}"] for i in range(1, 5)] == [1.0, 2.0, 0.0, 0.0]
    assert embedded_guard(HelixdConfig(), 1.0)["HXG_TIMEOUT"] == 0.5
