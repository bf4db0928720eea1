"""``helixd serve`` on the command line: usage errors are one line and exit 2, before anything
connects; --sim-gcs gives the embedded simulator its second link."""

from __future__ import annotations

from typing import Any

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.sim.sim_config import SimConfig
from tests.support.cli import run_main
from tests.support.simcore import EmbeddedStart

GCS_URL = "udpout:127.0.0.1:14550"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--sim-gcs", "udpout:127.0.0.1:14550"], "error: --sim-gcs needs --sim"),
        (["--sim", "--sim-gcs", "udpout:nowhere"], "error: --sim-gcs: "),
        (["--sim", "--connect", "udpin:0.0.0.0:14550"], "error: --sim and --connect exclude"),
    ],
)
def test_usage_errors_are_one_line(
    args: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    code, _, err = run_main(["serve", *args], capsys)
    assert code == ExitCode.USAGE
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(message), err


def test_sim_gcs_reaches_the_embedded_simulator(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import helixd.cli.simulated

    links: list[tuple[str, ...]] = []

    def start(cfg: SimConfig, extra_links: tuple[str, ...] = (), judge_pace: bool = False) -> Any:
        assert judge_pace  # serve --sim lowers a speed-up the machine does not keep too
        links.append(extra_links)
        raise EmbeddedStart

    monkeypatch.setattr(helixd.cli.simulated, "start_embedded", start)
    with pytest.raises(EmbeddedStart):
        run_main(
            ["serve", "--sim", "--sim-gcs", "udpout:127.0.0.1:14550", "--mode", "roll"], capsys
        )
    assert links == [(GCS_URL,)]


def test_serve_help_says_how_a_ground_station_starts_a_flight(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Before: `serve -h` named the start switch and MISSION_START but not AUTO, the way
    QGroundControl's Start Mission and every flight-mode menu start and continue a flight."""
    code, out, _ = run_main(["serve", "-h"], capsys)
    text = " ".join(out.split())
    assert code == 0
    assert "armed in AUTO" in text and "HOLD then AUTO again" in text
