"""``run --sim``: the embedded simulator comes with helixd-guard installed, guarding the
config's scroll outputs, its timeout 0.5 s of wall time at any speed-up."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.cli.app import main
from helixd.cli.simulated import embedded_guard
from helixd.config.root import HelixdConfig
from tests.support.cli import run_main
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


def test_run_sim_console_is_one_format_and_ends_with_the_result_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: ``make demo`` printed the simulator's lines in another format (before the
    run's logging was set up) and its ``sim_stopped`` after the RESULT line. A run refused at
    preflight (the start outside the mission's fence) is the quickest whole run."""
    mission = tmp_path / "fenced.yaml"
    mission.write_text(
        "name: fenced\nmode: roll\nframe: global\n"
        "waypoints:\n  - {lat: 53.52370, lon: -113.52632}\n  - {lat: 53.52380, lon: -113.52632}\n"
        "geofence_polygon:\n  - [53.52360, -113.52650]\n  - [53.52390, -113.52650]\n"
        "  - [53.52390, -113.52610]\n  - [53.52360, -113.52610]\n",
        encoding="utf-8",
    )
    code, out, err = run_main(
        ["run", "--sim", "--sim-speedup", "10", "--mission", str(mission), "--log-level",
         "warning", "--run-dir", str(tmp_path / "runs")],
        capsys,
    )  # fmt: skip
    assert code == 3, err
    assert "sim_started" not in out + err and "sim_stopped" not in out + err
    lines = [line for line in err.splitlines() if line.strip()]
    assert lines[-1].startswith("helixd: RESULT refused preflight: the start point")
    assert not [line for line in lines if "level=info" in line]
